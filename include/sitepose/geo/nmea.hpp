#pragma once
// NMEA 0183 GGA and RMC sentences → GnssFix, for tests and replay of
// recorded receiver output. Pure parsing (read_nmea_file also reads a file).
//
// A fix comes from each GGA sentence (position, quality, satellites, HDOP,
// ellipsoidal height = altitude above MSL + geoidal separation). GGA carries
// only the time of day, so the date comes from the RMC sentence nearest in
// the file (midnight roll-over handled); a file without RMC is an error.
// Every sentence must carry a correct "*hh" checksum. Talker ids are not
// checked ($GP, $GN, $GL, ...); sentence types other than GGA/RMC are
// counted and skipped.

#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/geo/gnss_fix.hpp"

namespace sitepose::geo {

struct GgaSentence {
  std::int64_t time_of_day_ns = 0;  // UTC since midnight
  GnssFix fix;                      // t_ns = time_of_day_ns until dated
};

struct RmcSentence {
  std::int64_t time_of_day_ns = 0;  // UTC since midnight
  std::int64_t days_since_epoch = 0;  // UTC date, days since 1970-01-01
  bool status_active = false;       // 'A' = valid, 'V' = warning
  Geodetic position;                // height NaN (RMC has none); NaN if empty
};

struct NmeaSentence {
  std::string talker;  // e.g. "GP", "GN"
  std::string type;    // e.g. "GGA", "RMC", "GSV"
  std::optional<GgaSentence> gga;  // set for type GGA
  std::optional<RmcSentence> rmc;  // set for type RMC
};

// One sentence, with or without the trailing CR/LF. The error message names
// the field (number and meaning), its text and what was expected; callers
// prefix the location.
Expected<NmeaSentence> parse_nmea_sentence(std::string_view line);

struct NmeaReadOptions {
  // false: the first bad line fails the whole read (tests, replay of trusted
  // logs). true: bad lines are counted in lines_rejected and skipped, as a
  // receiver stream with occasional corruption needs.
  bool skip_bad_lines = false;
};

struct NmeaReadResult {
  std::vector<GnssFix> fixes;   // one per GGA, in file order
  int lines_read = 0;
  int sentences_ignored = 0;    // well-formed, neither GGA nor RMC
  int lines_rejected = 0;       // only with skip_bad_lines
  std::string first_rejection;  // "<source>:<line>: why" of the first one
};

// Errors name "<source_name>:<line>: ...". Blank lines are allowed.
Expected<NmeaReadResult> read_nmea_stream(std::istream& in, const std::string& source_name,
                                          const NmeaReadOptions& options);
// kNotFound when the file cannot be opened.
Expected<NmeaReadResult> read_nmea_file(const std::string& path, const NmeaReadOptions& options);

}  // namespace sitepose::geo
