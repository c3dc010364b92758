#pragma once
// One GNSS receiver fix as the site anchoring consumes it, whatever carried
// it (NMEA text, LCM gnss_fix_t).

#include <cmath>
#include <cstdint>

#include "sitepose/geo/geodetic.hpp"

namespace sitepose::geo {

// The NMEA GGA fix-quality field (same numbers in gnss_fix_t.lcm).
enum class GnssQuality : int {
  kInvalid = 0,
  kGps = 1,
  kDgps = 2,
  kPps = 3,
  kRtkFixed = 4,
  kRtkFloat = 5,
  kEstimated = 6,
  kManual = 7,
  kSimulation = 8,
};

const char* to_string(GnssQuality quality);
// kInvalidArgument unless 0 <= value <= 8.
Expected<GnssQuality> gnss_quality_from_int(int value);

struct GnssFix {
  // Fix time, UTC nanoseconds since the Unix epoch (NMEA: date of the RMC
  // sentence + time of the GGA sentence). The anchoring shifts it onto the
  // camera clock with its configured offset.
  std::int64_t t_ns = 0;
  // Antenna position; NaN latitude/longitude when the receiver has none
  // (quality kInvalid with empty GGA fields).
  Geodetic position;
  GnssQuality quality = GnssQuality::kInvalid;
  int num_satellites = 0;
  double hdop = 0.0;  // NaN when the receiver does not report it

  bool has_position() const {
    return std::isfinite(position.latitude_deg) && std::isfinite(position.longitude_deg) &&
           std::isfinite(position.height_m);
  }
};

}  // namespace sitepose::geo
