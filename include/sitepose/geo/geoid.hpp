#pragma once
// The geoid: its height N above the WGS84 ellipsoid, so that a height above
// mean sea level is H = h_ellipsoid - N. Read from a PROJ GTX grid (Debian
// proj-data: /usr/share/proj/egm96_15.gtx, EGM96 on a 15' grid): a 40-byte
// big-endian header (lat0, lon0, dlat, dlon as doubles, degrees, the
// south-west node; rows, cols as int32) then rows x cols big-endian float32,
// rows from south to north, each west to east; -88.8888 marks no data.
// Bilinear interpolation between the four nodes around a point; longitudes
// wrap around the globe. Immutable after load(); safe to share between
// threads.

#include <memory>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::geo {

inline constexpr char kDefaultGeoidPath[] = "/usr/share/proj/egm96_15.gtx";

class GeoidGrid {
 public:
  // Fails naming the file: missing, truncated, a header that is not a
  // grid (non-finite or non-positive spacing, sizes that do not match the
  // file's length).
  static Expected<GeoidGrid> load(const std::string& path);

  // N in metres at a WGS84 latitude / longitude (degrees). Fails outside
  // the grid's latitudes or where a surrounding node has no data.
  Expected<double> height_above_ellipsoid_m(double latitude_deg, double longitude_deg) const;

  const std::string& path() const { return path_; }

 private:
  GeoidGrid() = default;
  double node(int row, int col) const { return (*values_)[static_cast<std::size_t>(row) * cols_ + col]; }

  std::string path_;
  double lat0_deg_ = 0.0, lon0_deg_ = 0.0, dlat_deg_ = 0.0, dlon_deg_ = 0.0;
  int rows_ = 0, cols_ = 0;
  bool wraps_ = false;  // the columns span the whole globe
  std::shared_ptr<const std::vector<float>> values_;
};

}  // namespace sitepose::geo
