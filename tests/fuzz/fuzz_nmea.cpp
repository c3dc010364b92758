// NMEA 0183 sentences (geo.online.nmea_file, a receiver stream): accepted
// fixes with a position lie on the WGS84 ellipsoid's coordinate ranges.
#include <cmath>
#include <sstream>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/geo/nmea.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  if (size == 0) return 0;
  const std::string_view text = fuzz::as_text(data + 1, size - 1);
  (void)geo::parse_nmea_sentence(text);
  std::istringstream in{std::string(text)};
  geo::NmeaReadOptions options;
  options.skip_bad_lines = (data[0] & 1) != 0;
  auto result = geo::read_nmea_stream(in, "fuzz.nmea", options);
  if (!result) return 0;
  for (const geo::GnssFix& fix : result->fixes) {
    if (!fix.has_position()) continue;
    fuzz::require(std::abs(fix.position.latitude_deg) <= 90.0, "latitude in -90..90");
    fuzz::require(std::abs(fix.position.longitude_deg) <= 180.0, "longitude in -180..180");
  }
  return 0;
}
