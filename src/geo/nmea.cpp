#include "sitepose/geo/nmea.hpp"

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>

#include <fmt/format.h>

namespace sitepose::geo {

namespace {

constexpr std::int64_t kNsPerSecond = 1'000'000'000;
constexpr std::int64_t kNsPerDay = 86'400 * kNsPerSecond;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Unexpected field_error(std::string_view type, int index, std::string_view meaning, std::string_view text,
                       std::string_view expected) {
  return make_error(ErrorCode::kParseError, fmt::format("{} field {} ({}) = '{}': expected {}", type, index,
                                                        meaning, text, expected));
}

std::vector<std::string_view> split_fields(std::string_view body) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = body.find(',', start);
    fields.push_back(body.substr(start, comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

std::optional<double> to_double(std::string_view text) {
  if (text.empty()) return std::nullopt;
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

std::optional<int> to_int(std::string_view text) {
  if (text.empty()) return std::nullopt;
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// hhmmss[.sss] -> ns since midnight.
Expected<std::int64_t> parse_time(std::string_view type, int index, std::string_view text) {
  const auto bad = [&] {
    return field_error(type, index, "UTC time", text, "hhmmss[.sss] with hh < 24, mm, ss < 60");
  };
  if (text.size() < 6) return bad();
  const auto hh = to_int(text.substr(0, 2));
  const auto mm = to_int(text.substr(2, 2));
  const auto ss = to_double(text.substr(4));
  if (!hh || !mm || !ss || *hh < 0 || *hh > 23 || *mm < 0 || *mm > 59 || *ss < 0.0 ||
      *ss >= 61.0 /* leap second */) {
    return bad();
  }
  return (*hh * 3600 + *mm * 60) * kNsPerSecond + std::llround(*ss * 1e9);
}

// ddmm.mmmm / dddmm.mmmm + hemisphere -> signed degrees; NaN when both empty.
Expected<double> parse_angle(std::string_view type, int index, std::string_view text,
                             std::string_view hemisphere, bool latitude) {
  const char* meaning = latitude ? "latitude ddmm.mmmm" : "longitude dddmm.mmmm";
  if (text.empty() && hemisphere.empty()) return kNaN;
  const auto value = to_double(text);
  const int degree_digits = latitude ? 2 : 3;
  const std::size_t dot = text.find('.');
  const std::size_t integer_digits = dot == std::string_view::npos ? text.size() : dot;
  if (!value || *value < 0.0 || integer_digits != static_cast<std::size_t>(degree_digits) + 2) {
    return field_error(type, index, meaning, text,
                       latitude ? "2 degree digits then minutes, e.g. 4807.038"
                                : "3 degree digits then minutes, e.g. 01131.000");
  }
  const double degrees = std::floor(*value / 100.0);
  const double minutes = *value - degrees * 100.0;
  const double limit = latitude ? 90.0 : 180.0;
  if (minutes >= 60.0 || degrees + minutes / 60.0 > limit) {
    return field_error(
        type, index, meaning, text,
        latitude ? "at most 90 degrees and minutes < 60" : "at most 180 degrees and minutes < 60");
  }
  double result = degrees + minutes / 60.0;
  const char positive = latitude ? 'N' : 'E';
  const char negative = latitude ? 'S' : 'W';
  if (hemisphere.size() != 1 || (hemisphere[0] != positive && hemisphere[0] != negative)) {
    return field_error(type, index + 1, latitude ? "N/S" : "E/W", hemisphere, latitude ? "N or S" : "E or W");
  }
  if (hemisphere[0] == negative) result = -result;
  return result;
}

// A sentence needs at least `minimum` fields; `expected` says how many, in words.
Status check_field_count(std::string_view type, const std::vector<std::string_view>& f, std::size_t minimum,
                         std::string_view expected) {
  if (f.size() >= minimum) return ok_status();
  return make_error(ErrorCode::kParseError,
                    fmt::format("{}: {} fields, expected {}", type, f.size(), expected));
}

Expected<GgaSentence> parse_gga(const std::vector<std::string_view>& f) {
  // $--GGA,time,lat,N,lon,E,quality,nsat,hdop,alt,M,sep,M,age,station
  SITEPOSE_TRY_STATUS(check_field_count("GGA", f, 15, "15 (time .. station id)"));
  GgaSentence s;
  SITEPOSE_TRY(s.time_of_day_ns, parse_time("GGA", 1, f[1]));
  SITEPOSE_TRY(s.fix.position.latitude_deg, parse_angle("GGA", 2, f[2], f[3], true));
  SITEPOSE_TRY(s.fix.position.longitude_deg, parse_angle("GGA", 4, f[4], f[5], false));
  const auto quality = to_int(f[6]);
  if (!quality || *quality < 0 || *quality > 8) {
    return field_error("GGA", 6, "fix quality", f[6], "an integer 0..8 (4 = RTK fixed, 5 = float)");
  }
  s.fix.quality = static_cast<GnssQuality>(*quality);
  if (f[7].empty()) {
    s.fix.num_satellites = 0;
  } else {
    const auto nsat = to_int(f[7]);
    if (!nsat || *nsat < 0 || *nsat > 99) {
      return field_error("GGA", 7, "satellites in use", f[7], "an integer 0..99");
    }
    s.fix.num_satellites = *nsat;
  }
  if (f[8].empty()) {
    s.fix.hdop = kNaN;
  } else {
    const auto hdop = to_double(f[8]);
    if (!hdop || *hdop < 0.0) return field_error("GGA", 8, "HDOP", f[8], "a number >= 0");
    s.fix.hdop = *hdop;
  }
  const bool has_lat = std::isfinite(s.fix.position.latitude_deg);
  const bool has_lon = std::isfinite(s.fix.position.longitude_deg);
  if (has_lat != has_lon) {
    return field_error("GGA", has_lat ? 4 : 2, has_lat ? "longitude" : "latitude", has_lat ? f[4] : f[2],
                       "both latitude and longitude, or neither");
  }
  const bool has_lat_lon = has_lat && has_lon;
  if (!has_lat_lon) {
    if (s.fix.quality != GnssQuality::kInvalid) {
      return field_error("GGA", 2, "latitude", f[2], "a position when fix quality is not 0");
    }
    s.fix.position.height_m = kNaN;
    return s;
  }
  const auto altitude = to_double(f[9]);
  if (!altitude) return field_error("GGA", 9, "altitude above MSL", f[9], "a number (m)");
  if (f[10] != "M") return field_error("GGA", 10, "altitude unit", f[10], "M");
  // Ellipsoidal height = MSL altitude + geoidal separation; without the
  // separation the height would be off by tens of metres, silently.
  const auto separation = to_double(f[11]);
  if (!separation) {
    return field_error("GGA", 11, "geoidal separation", f[11],
                       "a number (m): the ellipsoidal height needs it");
  }
  if (f[12] != "M") return field_error("GGA", 12, "separation unit", f[12], "M");
  s.fix.position.height_m = *altitude + *separation;
  return s;
}

Expected<RmcSentence> parse_rmc(const std::vector<std::string_view>& f) {
  // $--RMC,time,status,lat,N,lon,E,sog,cog,ddmmyy,magvar,E[,mode[,nav status]]
  SITEPOSE_TRY_STATUS(check_field_count("RMC", f, 12, "at least 12 (time .. variation E/W)"));
  RmcSentence s;
  SITEPOSE_TRY(s.time_of_day_ns, parse_time("RMC", 1, f[1]));
  if (f[2] != "A" && f[2] != "V") return field_error("RMC", 2, "status", f[2], "A or V");
  s.status_active = f[2] == "A";
  SITEPOSE_TRY(s.position.latitude_deg, parse_angle("RMC", 3, f[3], f[4], true));
  SITEPOSE_TRY(s.position.longitude_deg, parse_angle("RMC", 5, f[5], f[6], false));
  s.position.height_m = kNaN;
  const std::string_view date = f[9];
  const auto dd = date.size() == 6 ? to_int(date.substr(0, 2)) : std::nullopt;
  const auto mo = date.size() == 6 ? to_int(date.substr(2, 2)) : std::nullopt;
  const auto yy = date.size() == 6 ? to_int(date.substr(4, 2)) : std::nullopt;
  if (!dd || !mo || !yy) return field_error("RMC", 9, "date", date, "ddmmyy");
  // Two-digit years: 80..99 -> 1980s/90s (GPS epoch), else 20xx.
  const int year = *yy >= 80 ? 1900 + *yy : 2000 + *yy;
  const std::chrono::year_month_day ymd{std::chrono::year{year},
                                        std::chrono::month{static_cast<unsigned>(*mo)},
                                        std::chrono::day{static_cast<unsigned>(*dd)}};
  if (*mo < 1 || *dd < 1 || !ymd.ok()) return field_error("RMC", 9, "date", date, "a valid ddmmyy date");
  s.days_since_epoch = std::chrono::sys_days{ymd}.time_since_epoch().count();
  return s;
}

}  // namespace

Expected<NmeaSentence> parse_nmea_sentence(std::string_view line) {
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n' || line.back() == ' ')) {
    line.remove_suffix(1);
  }
  if (line.empty() || line[0] != '$') {
    return make_error(ErrorCode::kParseError,
                      fmt::format("'{}': expected a sentence starting with '$'", line.substr(0, 20)));
  }
  const std::size_t star = line.rfind('*');
  if (star == std::string_view::npos || star + 3 != line.size()) {
    return make_error(ErrorCode::kParseError, "missing checksum: expected the sentence to end with '*hh'");
  }
  const std::string_view body = line.substr(1, star - 1);
  unsigned expected_checksum = 0;
  const std::string_view hex = line.substr(star + 1, 2);
  const auto [end, ec] = std::from_chars(hex.data(), hex.data() + 2, expected_checksum, 16);
  if (ec != std::errc() || end != hex.data() + 2) {
    return make_error(ErrorCode::kParseError,
                      fmt::format("checksum '{}': expected two hexadecimal digits", hex));
  }
  unsigned checksum = 0;
  for (const char c : body) checksum ^= static_cast<unsigned char>(c);
  if (checksum != expected_checksum) {
    return make_error(ErrorCode::kParseError,
                      fmt::format("checksum mismatch: sentence says {:02X}, content gives {:02X}",
                                  expected_checksum, checksum));
  }
  const std::vector<std::string_view> fields = split_fields(body);
  if (fields[0].size() != 5) {
    return make_error(ErrorCode::kParseError,
                      fmt::format("address field '{}': expected 2-letter talker + 3-letter type", fields[0]));
  }
  NmeaSentence sentence;
  sentence.talker = std::string(fields[0].substr(0, 2));
  sentence.type = std::string(fields[0].substr(2));
  if (sentence.type == "GGA") {
    SITEPOSE_TRY(GgaSentence gga, parse_gga(fields));
    sentence.gga = gga;
  } else if (sentence.type == "RMC") {
    SITEPOSE_TRY(RmcSentence rmc, parse_rmc(fields));
    sentence.rmc = rmc;
  }
  return sentence;
}

Expected<NmeaReadResult> read_nmea_stream(std::istream& in, const std::string& source_name,
                                          const NmeaReadOptions& options) {
  struct DatedRmc {
    int line;
    std::int64_t time_of_day_ns;
    std::int64_t days;
  };
  struct PendingGga {
    int line;
    GgaSentence gga;
  };
  NmeaReadResult result;
  std::vector<DatedRmc> rmcs;
  std::vector<PendingGga> ggas;
  std::string text;
  int line_number = 0;
  while (std::getline(in, text)) {
    ++line_number;
    std::string_view view(text);
    while (!view.empty() && (view.back() == '\r' || view.back() == ' ' || view.back() == '\t')) {
      view.remove_suffix(1);
    }
    if (view.empty()) continue;
    ++result.lines_read;
    auto sentence = parse_nmea_sentence(view);
    if (!sentence) {
      const std::string where = fmt::format("{}:{}: {}", source_name, line_number, sentence.error().message);
      if (!options.skip_bad_lines) return make_error(sentence.error().code, where);
      if (result.lines_rejected++ == 0) result.first_rejection = where;
      continue;
    }
    if (sentence->gga) {
      ggas.push_back({line_number, *sentence->gga});
    } else if (sentence->rmc) {
      rmcs.push_back({line_number, sentence->rmc->time_of_day_ns, sentence->rmc->days_since_epoch});
    } else {
      ++result.sentences_ignored;
    }
  }
  if (in.bad()) {
    return make_error(ErrorCode::kIoError,
                      fmt::format("{}: read error after line {}", source_name, line_number));
  }
  if (!ggas.empty() && rmcs.empty()) {
    return make_error(ErrorCode::kParseError,
                      fmt::format("{}:{}: GGA sentence but no RMC sentence in the file: the date "
                                  "of the fixes is unknown",
                                  source_name, ggas.front().line));
  }
  // Date each GGA with the RMC nearest in the file; across midnight the two
  // times of day differ by almost a day, which moves the date by one.
  std::size_t next_rmc = 0;
  for (const PendingGga& g : ggas) {
    while (next_rmc < rmcs.size() && rmcs[next_rmc].line < g.line) ++next_rmc;
    const DatedRmc* nearest = nullptr;
    if (next_rmc == rmcs.size()) {
      nearest = &rmcs.back();
    } else if (next_rmc == 0) {
      nearest = &rmcs.front();
    } else {
      const DatedRmc& before = rmcs[next_rmc - 1];
      const DatedRmc& after = rmcs[next_rmc];
      nearest = (g.line - before.line) <= (after.line - g.line) ? &before : &after;
    }
    std::int64_t days = nearest->days;
    const std::int64_t diff_ns = g.gga.time_of_day_ns - nearest->time_of_day_ns;
    if (diff_ns > kNsPerDay / 2) --days;
    if (diff_ns < -kNsPerDay / 2) ++days;
    GnssFix fix = g.gga.fix;
    fix.t_ns = days * kNsPerDay + g.gga.time_of_day_ns;
    result.fixes.push_back(fix);
  }
  return result;
}

Expected<NmeaReadResult> read_nmea_file(const std::string& path, const NmeaReadOptions& options) {
  std::ifstream in(path);
  if (!in) {
    return make_error(ErrorCode::kNotFound, fmt::format("{}: cannot open NMEA file", path));
  }
  return read_nmea_stream(in, path, options);
}

}  // namespace sitepose::geo
