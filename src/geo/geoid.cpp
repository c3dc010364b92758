#include "sitepose/geo/geoid.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

namespace sitepose::geo {

namespace {

constexpr std::size_t kHeaderBytes = 40;
constexpr float kNoData = -88.8888f;

template <typename T>
T big_endian(const unsigned char* p) {
  using U = std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t>;
  U u = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) u = static_cast<U>((u << 8) | p[i]);
  return std::bit_cast<T>(u);
}

}  // namespace

Expected<GeoidGrid> GeoidGrid::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return make_error(ErrorCode::kNotFound,
                      fmt::format("geoid grid {}: cannot open: {}", path, std::strerror(errno)));
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
  auto bad = [&](const std::string& why) {
    return make_error(ErrorCode::kParseError, fmt::format("geoid grid {}: {}", path, why));
  };
  if (bytes.size() < kHeaderBytes) return bad("shorter than the 40-byte GTX header");
  GeoidGrid g;
  g.path_ = path;
  g.lat0_deg_ = big_endian<double>(&bytes[0]);
  g.lon0_deg_ = big_endian<double>(&bytes[8]);
  g.dlat_deg_ = big_endian<double>(&bytes[16]);
  g.dlon_deg_ = big_endian<double>(&bytes[24]);
  g.rows_ = big_endian<std::int32_t>(&bytes[32]);
  g.cols_ = big_endian<std::int32_t>(&bytes[36]);
  if (!std::isfinite(g.lat0_deg_) || !std::isfinite(g.lon0_deg_) || !(g.dlat_deg_ > 0.0) ||
      !(g.dlon_deg_ > 0.0) || g.rows_ < 2 || g.cols_ < 2 || g.rows_ > 100000 || g.cols_ > 100000) {
    return bad("header is not a GTX grid (origin, spacing or size out of range)");
  }
  const std::size_t n = static_cast<std::size_t>(g.rows_) * static_cast<std::size_t>(g.cols_);
  if (bytes.size() != kHeaderBytes + 4 * n) {
    return bad(fmt::format("{} bytes, the header's {} x {} grid needs {}", bytes.size(), g.rows_, g.cols_,
                           kHeaderBytes + 4 * n));
  }
  auto values = std::make_shared<std::vector<float>>(n);
  for (std::size_t i = 0; i < n; ++i) (*values)[i] = big_endian<float>(&bytes[kHeaderBytes + 4 * i]);
  g.values_ = std::move(values);
  g.wraps_ = g.dlon_deg_ * g.cols_ >= 360.0 - 1e-9;
  return g;
}

Expected<double> GeoidGrid::height_above_ellipsoid_m(double latitude_deg, double longitude_deg) const {
  if (!std::isfinite(latitude_deg) || !std::isfinite(longitude_deg)) {
    return make_error(ErrorCode::kInvalidArgument, "geoid: latitude / longitude not finite");
  }
  const double y = (latitude_deg - lat0_deg_) / dlat_deg_;
  double x = (longitude_deg - lon0_deg_) / dlon_deg_;
  const double period = 360.0 / dlon_deg_;
  if (wraps_) x = std::fmod(std::fmod(x, period) + period, period);
  if (y < 0.0 || y > rows_ - 1 || x < 0.0 || (!wraps_ && x > cols_ - 1)) {
    return make_error(ErrorCode::kInvalidArgument, fmt::format("geoid grid {}: {:.6f}, {:.6f} is outside it",
                                                               path_, latitude_deg, longitude_deg));
  }
  const int r0 = std::min(static_cast<int>(y), rows_ - 2);
  const int c0 = std::min(static_cast<int>(x), cols_ - 1);
  // The column after the last is the first again on a grid that wraps.
  const int c1 = c0 + 1 < cols_ ? c0 + 1 : (wraps_ ? 0 : c0);
  const double fy = y - r0, fx = x - c0;
  const double v00 = node(r0, c0), v01 = node(r0, c1), v10 = node(r0 + 1, c0), v11 = node(r0 + 1, c1);
  for (double v : {v00, v01, v10, v11}) {
    if (std::abs(v - kNoData) < 1e-3) {
      return make_error(ErrorCode::kInvalidArgument, fmt::format("geoid grid {}: no data near {:.6f}, {:.6f}",
                                                                 path_, latitude_deg, longitude_deg));
    }
  }
  return (1 - fy) * ((1 - fx) * v00 + fx * v01) + fy * ((1 - fx) * v10 + fx * v11);
}

}  // namespace sitepose::geo
