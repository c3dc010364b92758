#include "sitepose/geo/gnss_fix.hpp"

#include <fmt/format.h>

namespace sitepose::geo {

const char* to_string(GnssQuality quality) {
  switch (quality) {
    case GnssQuality::kInvalid: return "invalid";
    case GnssQuality::kGps: return "gps";
    case GnssQuality::kDgps: return "dgps";
    case GnssQuality::kPps: return "pps";
    case GnssQuality::kRtkFixed: return "rtk-fixed";
    case GnssQuality::kRtkFloat: return "rtk-float";
    case GnssQuality::kEstimated: return "estimated";
    case GnssQuality::kManual: return "manual";
    case GnssQuality::kSimulation: return "simulation";
  }
  return "unknown";
}

Expected<GnssQuality> gnss_quality_from_int(int value) {
  if (value < 0 || value > 8) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("fix quality = {}: expected 0..8 (NMEA GGA field 6)", value));
  }
  return static_cast<GnssQuality>(value);
}

}  // namespace sitepose::geo
