#pragma once
// Rigid alignment (rotation + translation, no scale) of point pairs with
// outliers: RANSAC over minimal 3-point samples with eval::umeyama_se3, then
// iterative refit on the inliers until the inlier set stops changing.
// Deterministic for a given seed. Pure computation.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"

namespace sitepose::geo {

struct RobustAlignmentOptions {
  double inlier_threshold_m = 0.05;  // |dst - T src| below this is an inlier
  int ransac_iterations = 100;
  int max_refits = 10;
  std::uint64_t seed = 7;
};

struct RobustAlignment {
  SE3 T_dst_src;
  std::vector<bool> inlier;  // per pair
  int num_inliers = 0;
  double inlier_rms_m = 0.0;  // residual RMS over the inliers
};

// Fails (kInvalidArgument) when the sizes differ, fewer than 3 pairs are
// given or the options are out of range; (kRuntime) when no sample yields 3
// inliers (all points (nearly) collinear or no consistent subset).
Expected<RobustAlignment> robust_umeyama_se3(const std::vector<Eigen::Vector3d>& p_src,
                                             const std::vector<Eigen::Vector3d>& p_dst,
                                             const RobustAlignmentOptions& options);

}  // namespace sitepose::geo
