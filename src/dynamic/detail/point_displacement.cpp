#include "point_displacement.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace sitepose::dynamic::detail {
namespace {

// A point agrees with its object's common displacement within chi2 3 dof
// 99 % of its pixel noise.
constexpr double kConsistencyGate = 11.34;

}  // namespace

bool gives_trusted_point(const tracking::PreparedFrame& frame, int k, double max_depth_m) {
  if (!frame.features.has_depth(k) || frame.features.depth_m[k] > max_depth_m) return false;
  return frame.features.stereo_ambiguous.empty() || !frame.features.stereo_ambiguous[k];
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t index =
      std::min(values.size() - 1, static_cast<std::size_t>(std::ceil(q * values.size())) - (q > 0 ? 1 : 0));
  return values[index];
}

// A rigid object, moving or not, displaces all its points alike; a keypoint
// matched to the wrong place (repeated texture: windows, tracks, grilles)
// does not. The tests then run on these points only, free of the mismatches
// (metres of "displacement" that would call a parked machine moving) and
// without favouring "static".
std::vector<bool> agrees_with_common(const std::vector<PointDisplacement>& points) {
  Eigen::Vector3d common;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> component;
    component.reserve(points.size());
    for (const PointDisplacement& p : points) component.push_back(p.d[axis]);
    common[axis] = quantile(std::move(component), 0.5);
  }
  std::vector<bool> out;
  out.reserve(points.size());
  for (const PointDisplacement& p : points) {
    const Eigen::Vector3d e = p.d - common;
    out.push_back(e.dot(p.pixel_covariance.ldlt().solve(e)) <= kConsistencyGate);
  }
  return out;
}

std::vector<PointDisplacement> consistent_points(const std::vector<PointDisplacement>& points) {
  const std::vector<bool> agrees = agrees_with_common(points);
  std::vector<PointDisplacement> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (agrees[i]) out.push_back(points[i]);
  }
  return out;
}

double pooled_statistic(const std::vector<PointDisplacement>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d pixel_sum = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d pose_sum = Eigen::Matrix3d::Zero();
  for (const PointDisplacement& p : points) {
    mean += p.d;
    pixel_sum += p.pixel_covariance;
    pose_sum += p.covariance - p.pixel_covariance;
  }
  const double n = static_cast<double>(points.size());
  mean /= n;
  const Eigen::Matrix3d sigma = pixel_sum / (n * n) + pose_sum / n;
  return mean.dot(sigma.ldlt().solve(mean));
}

CommonDisplacement weighted_common_displacement(const std::vector<PointDisplacement>& points,
                                                double common_error_fraction) {
  CommonDisplacement out;
  if (points.empty()) return out;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d weighted_sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d pose_term = Eigen::Matrix3d::Zero();
  double pose_weight = 0.0;
  for (const PointDisplacement& p : points) {
    const Eigen::Matrix3d W = p.pixel_covariance.inverse();
    information += W;
    weighted_sum += W * p.d;
    // The pose term is common to all points; averaged with a scalar weight
    // close to the mean's (a near point's share dominates both).
    const double w = 1.0 / p.pixel_covariance.trace();
    pose_term += w * (p.covariance - p.pixel_covariance);
    pose_weight += w;
  }
  const Eigen::Matrix3d mean_covariance = information.inverse();
  const double n = static_cast<double>(points.size());
  out.mean_m = mean_covariance * weighted_sum;
  // n * mean_covariance: one point's pixel covariance as the weighting sees
  // it (the near points'; a plain average would be ruled by the far ones).
  out.covariance = mean_covariance + pose_term / pose_weight +
                   common_error_fraction * common_error_fraction * n * mean_covariance;
  out.statistic = out.mean_m.dot(out.covariance.ldlt().solve(out.mean_m));
  return out;
}

}  // namespace sitepose::dynamic::detail
