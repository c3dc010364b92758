#include "sitepose/geo/nmea.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "sitepose/testing/files.hpp"

namespace sitepose::geo {
namespace {

std::string sentence(const std::string& body) {
  unsigned checksum = 0;
  for (char c : body) checksum ^= static_cast<unsigned char>(c);
  char tail[8];
  std::snprintf(tail, sizeof(tail), "*%02X", checksum);
  return "$" + body + tail;
}

constexpr std::int64_t kNs = 1'000'000'000;

TEST(Nmea, ParsesTheTextbookGgaAndRmc) {
  // The classic examples (checksums as published).
  auto gga = parse_nmea_sentence("$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n");
  ASSERT_TRUE(gga.has_value()) << gga.error().message;
  EXPECT_EQ(gga->talker, "GP");
  EXPECT_EQ(gga->type, "GGA");
  ASSERT_TRUE(gga->gga.has_value());
  EXPECT_EQ(gga->gga->time_of_day_ns, (12 * 3600 + 35 * 60 + 19) * kNs);
  EXPECT_NEAR(gga->gga->fix.position.latitude_deg, 48.0 + 7.038 / 60.0, 1e-12);
  EXPECT_NEAR(gga->gga->fix.position.longitude_deg, 11.0 + 31.0 / 60.0, 1e-12);
  EXPECT_NEAR(gga->gga->fix.position.height_m, 545.4 + 46.9, 1e-9);
  EXPECT_EQ(gga->gga->fix.quality, GnssQuality::kGps);
  EXPECT_EQ(gga->gga->fix.num_satellites, 8);
  EXPECT_DOUBLE_EQ(gga->gga->fix.hdop, 0.9);

  auto rmc = parse_nmea_sentence("$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A");
  ASSERT_TRUE(rmc.has_value()) << rmc.error().message;
  ASSERT_TRUE(rmc->rmc.has_value());
  EXPECT_TRUE(rmc->rmc->status_active);
  EXPECT_EQ(rmc->rmc->days_since_epoch, 8847);  // 1994-03-23
  EXPECT_NEAR(rmc->rmc->position.latitude_deg, 48.1173, 1e-9);
}

TEST(Nmea, RtkQualitiesSouthWestAndFractionalSeconds) {
  auto s = parse_nmea_sentence(
      sentence("GNGGA,235959.95,3351.1280,S,15112.5580,W,4,21,0.6,10.0,M,22.5,M,1.0,0123"));
  ASSERT_TRUE(s.has_value()) << s.error().message;
  EXPECT_EQ(s->gga->fix.quality, GnssQuality::kRtkFixed);
  EXPECT_EQ(s->gga->time_of_day_ns, 86399 * kNs + 950'000'000);
  EXPECT_NEAR(s->gga->fix.position.latitude_deg, -(33.0 + 51.128 / 60.0), 1e-12);
  EXPECT_NEAR(s->gga->fix.position.longitude_deg, -(151.0 + 12.558 / 60.0), 1e-12);
  auto f = parse_nmea_sentence(
      sentence("GPGGA,000001,3351.1280,N,15112.5580,E,5,12,1.1,10.0,M,22.5,M,,"));
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->gga->fix.quality, GnssQuality::kRtkFloat);
  // No fix: empty position is valid and reported as such.
  auto none = parse_nmea_sentence(sentence("GPGGA,000002,,,,,0,00,,,M,,M,,"));
  ASSERT_TRUE(none.has_value()) << none.error().message;
  EXPECT_EQ(none->gga->fix.quality, GnssQuality::kInvalid);
  EXPECT_FALSE(none->gga->fix.has_position());
  // Other sentence types parse (checksum checked) but carry nothing.
  auto gsv = parse_nmea_sentence(sentence("GPGSV,3,1,11,03,03,111,00"));
  ASSERT_TRUE(gsv.has_value());
  EXPECT_FALSE(gsv->gga.has_value());
  EXPECT_FALSE(gsv->rmc.has_value());
}

TEST(Nmea, RejectsBadChecksumsAndNamesMalformedFields) {
  auto bad_sum = parse_nmea_sentence("$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*48");
  ASSERT_FALSE(bad_sum.has_value());
  EXPECT_NE(bad_sum.error().message.find("checksum mismatch: sentence says 48, content gives 47"),
            std::string::npos) << bad_sum.error().message;
  EXPECT_FALSE(parse_nmea_sentence("$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,").has_value());
  EXPECT_FALSE(parse_nmea_sentence("GPGGA,123519*47").has_value());
  EXPECT_FALSE(parse_nmea_sentence("$GPGGA,1*ZZ").has_value());

  const std::vector<std::pair<std::string, std::string>> cases = {
      {"GPGGA,1235,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "GGA field 1 (UTC time) = '1235'"},
      {"GPGGA,126019,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "GGA field 1 (UTC time)"},
      {"GPGGA,123519,48x7.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "GGA field 2 (latitude"},
      {"GPGGA,123519,4867.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "minutes < 60"},
      {"GPGGA,123519,4807.038,X,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "GGA field 3 (N/S) = 'X'"},
      {"GPGGA,123519,4807.038,N,1131.000,E,1,08,0.9,545.4,M,46.9,M,,", "GGA field 4 (longitude"},
      {"GPGGA,123519,4807.038,N,01131.000,E,9,08,0.9,545.4,M,46.9,M,,", "GGA field 6 (fix quality) = '9'"},
      {"GPGGA,123519,4807.038,N,01131.000,E,4,08,0.9,545.4,M,,M,,", "GGA field 11 (geoidal separation)"},
      {"GPGGA,123519,4807.038,N,01131.000,E,4,08,0.9,,M,46.9,M,,", "GGA field 9 (altitude above MSL)"},
      {"GPGGA,123519,4807.038,N,01131.000,E,4", "GGA: 7 fields, expected 15"},
      {"GPGGA,123519,,,,,4,08,0.9,545.4,M,46.9,M,,", "a position when fix quality is not 0"},
      {"GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,320394,003.1,W", "RMC field 9 (date) = '320394'"},
      {"GPRMC,123519,Q,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W", "RMC field 2 (status) = 'Q'"},
  };
  for (const auto& [body, expected] : cases) {
    auto r = parse_nmea_sentence(sentence(body));
    ASSERT_FALSE(r.has_value()) << body;
    EXPECT_EQ(r.error().code, ErrorCode::kParseError);
    EXPECT_NE(r.error().message.find(expected), std::string::npos)
        << "got: " << r.error().message << "\nwanted: " << expected;
  }
}

TEST(Nmea, FileDatesGgaFromRmcAcrossMidnightAndNamesTheLine) {
  std::stringstream text;
  text << sentence("GPRMC,235959.80,A,4807.038,N,01131.000,E,0.1,84.4,311223,,") << "\r\n"
       << sentence("GPGGA,235959.80,4807.038,N,01131.000,E,4,14,0.7,545.4,M,46.9,M,1.2,0001") << "\n"
       << "\n"
       << sentence("GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1") << "\n"
       << sentence("GPGGA,000000.00,4807.039,N,01131.000,E,5,14,0.7,545.4,M,46.9,M,1.2,0001") << "\n"
       << sentence("GPRMC,000000.20,A,4807.039,N,01131.000,E,0.1,84.4,010124,,") << "\n";
  auto r = read_nmea_stream(text, "log.nmea", {});
  ASSERT_TRUE(r.has_value()) << r.error().message;
  ASSERT_EQ(r->fixes.size(), 2u);
  EXPECT_EQ(r->lines_read, 5);
  EXPECT_EQ(r->sentences_ignored, 1);
  // 2023-12-31 = 19722 days since 1970-01-01.
  const std::int64_t day_ns = 86400 * kNs;
  EXPECT_EQ(r->fixes[0].t_ns, 19722 * day_ns + 86399 * kNs + 800'000'000);
  EXPECT_EQ(r->fixes[1].t_ns, 19723 * day_ns);
  EXPECT_EQ(r->fixes[0].quality, GnssQuality::kRtkFixed);
  EXPECT_EQ(r->fixes[1].quality, GnssQuality::kRtkFloat);

  // The same with a corrupted third sentence: strict fails naming line 4,
  // lenient skips and counts it.
  std::string corrupted = text.str();
  const std::size_t gsa = corrupted.find("$GPGSA");
  corrupted[gsa + 8] = '9';
  std::stringstream strict_in(corrupted);
  auto strict = read_nmea_stream(strict_in, "log.nmea", {});
  ASSERT_FALSE(strict.has_value());
  EXPECT_EQ(strict.error().message.rfind("log.nmea:4: checksum mismatch", 0), 0u)
      << strict.error().message;
  std::stringstream lenient_in(corrupted);
  auto lenient = read_nmea_stream(lenient_in, "log.nmea", {.skip_bad_lines = true});
  ASSERT_TRUE(lenient.has_value());
  EXPECT_EQ(lenient->fixes.size(), 2u);
  EXPECT_EQ(lenient->lines_rejected, 1);
  EXPECT_EQ(lenient->first_rejection.rfind("log.nmea:4:", 0), 0u);
}

TEST(Nmea, FileWithoutRmcOrMissingFileFails) {
  std::stringstream text;
  text << sentence("GPGSV,3,1,11,03,03,111,00") << "\n"
       << sentence("GPGGA,123519,4807.038,N,01131.000,E,4,08,0.9,545.4,M,46.9,M,,") << "\n";
  auto r = read_nmea_stream(text, "x.nmea", {});
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("x.nmea:2: GGA sentence but no RMC"), std::string::npos);
  auto missing = read_nmea_file("/nonexistent/dir/fixes.nmea", {});
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);

  const testing::TempDir dir;
  const std::string path =
      dir.write("fixes.nmea", sentence("GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W") + "\n" +
                                  sentence("GPGGA,123519,4807.038,N,01131.000,E,4,08,0.9,545.4,M,46.9,M,,") + "\n");
  auto file = read_nmea_file(path, {});
  ASSERT_TRUE(file.has_value()) << file.error().message;
  ASSERT_EQ(file->fixes.size(), 1u);
  EXPECT_EQ(file->fixes[0].t_ns, 8847 * 86400 * kNs + (12 * 3600 + 35 * 60 + 19) * kNs);
}

}  // namespace
}  // namespace sitepose::geo
