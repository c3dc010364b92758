#pragma once
// WGS84 geodetic positions and their local East-North-Up (ENU) and UTM/UPS
// forms, computed with GeographicLib (kept out of this header). Pure
// computation; every class here is immutable after construction and safe to
// share between threads.

#include <memory>
#include <string>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"

namespace GeographicLib {
class LocalCartesian;
}

namespace sitepose::geo {

// A WGS84 position: latitude/longitude in degrees, ellipsoidal height in m
// (not height above mean sea level).
struct Geodetic {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double height_m = 0.0;
};

// Fails (kInvalidArgument, naming `what` and the value) unless latitude is in
// [-90, 90], longitude in [-180, 180] and all values are finite.
Status validate_geodetic(const Geodetic& position, const std::string& what);

// UTM (zone 1..60) or UPS (zone 0, polar) grid coordinates.
struct UtmPosition {
  double easting_m = 0.0;
  double northing_m = 0.0;
  int zone = 0;        // 1..60 for UTM, 0 for UPS
  bool north = true;   // hemisphere
};

// The standard UTM/UPS zone of the position (GeographicLib::UTMUPS::Forward).
Expected<UtmPosition> to_utm(const Geodetic& position);
// Inverse of to_utm.
Expected<Geodetic> from_utm(const UtmPosition& utm, double height_m);

// The local ENU frame tangent to the WGS84 ellipsoid at an origin:
// x = East, y = North, z = Up, metres (GeographicLib::LocalCartesian, exact
// geocentric rotation, no flat-earth approximation).
class LocalEnu {
 public:
  static Expected<LocalEnu> create(const Geodetic& origin);

  const Geodetic& origin() const { return origin_; }
  Eigen::Vector3d to_enu(const Geodetic& position) const;
  Geodetic to_geodetic(const Eigen::Vector3d& p_enu_m) const;

 private:
  LocalEnu(const Geodetic& origin, std::shared_ptr<const GeographicLib::LocalCartesian> impl)
      : origin_(origin), impl_(std::move(impl)) {}

  Geodetic origin_;
  std::shared_ptr<const GeographicLib::LocalCartesian> impl_;  // never null
};

}  // namespace sitepose::geo
