#pragma once
// Sub-pixel minimum of three equally spaced costs (private to features).

#include <optional>

namespace sitepose::features::detail {

// Vertex offset (in samples, relative to the middle sample) of the parabola
// through (-1, c_minus), (0, c_mid), (+1, c_plus). nullopt when the parabola
// does not open upwards (flat or concave costs: no defined minimum) or the
// vertex lies more than one sample away (the middle was not a minimum).
inline std::optional<double> parabola_vertex_offset(double c_minus, double c_mid, double c_plus) {
  const double curvature = c_minus + c_plus - 2.0 * c_mid;
  if (!(curvature > 0.0)) return std::nullopt;
  const double offset = 0.5 * (c_minus - c_plus) / curvature;
  if (offset < -1.0 || offset > 1.0) return std::nullopt;
  return offset;
}

}  // namespace sitepose::features::detail
