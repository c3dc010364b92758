#pragma once
// The displacement of an object's points between two sightings, and the
// object-level tests on it (sitepose mode). Shared by the reference-frame
// test (motion_classifier.cpp) and the map test (map_check.cpp).

#include <vector>

#include <Eigen/Core>

#include "sitepose/tracking/prepared_frame.hpp"

namespace sitepose::dynamic::detail {

// chi2 quantile of 3 dof at 99.9 %: the gate of the object-level tests (the
// reference-frame test's pooled statistic, the map test's common
// displacement) and of a single moving point. A static object trips it once
// in a thousand frames.
constexpr double kChi2ThreeDof999 = 16.27;

// Whether keypoint k of `frame` gives a stereo point the object tests can
// use: it has depth, no deeper than max_depth_m, and an unambiguous stereo
// match (a wrong one looks like motion of several metres).
bool gives_trusted_point(const tracking::PreparedFrame& frame, int k, double max_depth_m);

// One point of an object: where the current frame (CF) sees it minus where
// it was (a reference frame's sighting, or its map point), world frame.
struct PointDisplacement {
  Eigen::Vector3d d = Eigen::Vector3d::Zero();  // m
  Eigen::Matrix3d pixel_covariance =
      Eigen::Matrix3d::Zero();  // of d from pixel noise alone (independent per point)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of d, pixel noise and CF's pose
  double mahalanobis2 = 0.0;                             // d' covariance^-1 d
  // Squared shift in the current left image between the keypoint and its
  // earlier sighting projected there, in units of the keypoint's pixel
  // noise: motion across the view. A wrong stereo partner moves a point
  // along its ray (depth) but not across the image.
  double image_shift2 = 0.0;
  // Where the current left image sees the point (px): which part of the
  // object's box it lies in.
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();
};

// The q-quantile of values (q in [0, 1]); 0 when empty.
double quantile(std::vector<double> values, double q);

// The points whose displacement agrees with the object's common one
// (component-wise median) within their own pixel noise (chi2 3 dof 99 %).
std::vector<PointDisplacement> consistent_points(const std::vector<PointDisplacement>& points);
// Per point whether it agrees with the common displacement (the points
// consistent_points() keeps).
std::vector<bool> agrees_with_common(const std::vector<PointDisplacement>& points);

// Squared Mahalanobis distance of the plain mean displacement: pixel noise
// averages over the points, the pose term (common to all) does not.
double pooled_statistic(const std::vector<PointDisplacement>& points);

// The object's common displacement as the inverse-pixel-covariance weighted
// mean (a far point with a metre of depth noise must not weigh like a near
// one), with its covariance: the weighted mean's pixel noise, the pose term
// (weighted like the points), and common_error_fraction^2 times one
// point's pixel covariance under the weighting (n times the mean's) for an
// error all points share (their map points' common error, which does not
// average out).
struct CommonDisplacement {
  Eigen::Vector3d mean_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double statistic = 0.0;  // mean' covariance^-1 mean
};
CommonDisplacement weighted_common_displacement(const std::vector<PointDisplacement>& points,
                                                double common_error_fraction);

}  // namespace sitepose::dynamic::detail
