#include "sitepose/geo/geodetic.hpp"

#include <cmath>

#include <GeographicLib/Constants.hpp>
#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <fmt/format.h>

namespace sitepose::geo {

Status validate_geodetic(const Geodetic& position, const std::string& what) {
  if (!std::isfinite(position.latitude_deg) || position.latitude_deg < -90.0 ||
      position.latitude_deg > 90.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}: latitude_deg = {}: expected a number in [-90, 90]", what,
                                  position.latitude_deg));
  }
  if (!std::isfinite(position.longitude_deg) || position.longitude_deg < -180.0 ||
      position.longitude_deg > 180.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}: longitude_deg = {}: expected a number in [-180, 180]", what,
                                  position.longitude_deg));
  }
  if (!std::isfinite(position.height_m)) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}: height_m = {}: expected a finite number", what,
                                  position.height_m));
  }
  return ok_status();
}

Expected<UtmPosition> to_utm(const Geodetic& position) {
  SITEPOSE_TRY_STATUS(validate_geodetic(position, "to_utm"));
  UtmPosition utm;
  // GeographicLib reports failure by exception; it must not cross our API.
  try {
    GeographicLib::UTMUPS::Forward(position.latitude_deg, position.longitude_deg, utm.zone,
                                   utm.north, utm.easting_m, utm.northing_m);
  } catch (const GeographicLib::GeographicErr& e) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("to_utm: latitude {} longitude {}: {}", position.latitude_deg,
                                  position.longitude_deg, e.what()));
  }
  return utm;
}

Expected<Geodetic> from_utm(const UtmPosition& utm, double height_m) {
  Geodetic position;
  position.height_m = height_m;
  try {
    GeographicLib::UTMUPS::Reverse(utm.zone, utm.north, utm.easting_m, utm.northing_m,
                                   position.latitude_deg, position.longitude_deg);
  } catch (const GeographicLib::GeographicErr& e) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("from_utm: zone {} {} easting {} northing {}: {}", utm.zone,
                                  utm.north ? "north" : "south", utm.easting_m, utm.northing_m,
                                  e.what()));
  }
  return position;
}

Expected<LocalEnu> LocalEnu::create(const Geodetic& origin) {
  SITEPOSE_TRY_STATUS(validate_geodetic(origin, "site origin"));
  auto impl = std::make_shared<const GeographicLib::LocalCartesian>(
      origin.latitude_deg, origin.longitude_deg, origin.height_m, GeographicLib::Geocentric::WGS84());
  return LocalEnu(origin, std::move(impl));
}

Eigen::Vector3d LocalEnu::to_enu(const Geodetic& position) const {
  Eigen::Vector3d p;
  impl_->Forward(position.latitude_deg, position.longitude_deg, position.height_m, p.x(), p.y(),
                 p.z());
  return p;
}

Geodetic LocalEnu::to_geodetic(const Eigen::Vector3d& p_enu_m) const {
  Geodetic position;
  impl_->Reverse(p_enu_m.x(), p_enu_m.y(), p_enu_m.z(), position.latitude_deg,
                 position.longitude_deg, position.height_m);
  return position;
}

}  // namespace sitepose::geo
