#pragma once
// Motion-only bundle adjustment (METHOD.md "Core tracker", ORB-SLAM2
// Optimizer::PoseOptimization): the camera pose is optimised against fixed
// world points with Huber-robust mono (u_l, v_l) and stereo (u_l, v_l, u_r)
// reprojection residuals, in `motion_ba_rounds` rounds of at most
// `motion_ba_iterations` Levenberg-Marquardt iterations. After every round
// each observation is re-classified by its chi^2 at the current pose
// (> chi2_mono / chi2_stereo, or the point not in front of the camera ->
// outlier); outliers sit out the next round but are re-tested after it. The
// Huber kernel (delta = sqrt(chi2 gate)) is dropped in the last round.
// Differences from ORB-SLAM2: each round starts from the previous round's
// pose (ORB-SLAM2 restarts from the initial pose), and observations behind
// the initial pose start as outliers.
//
// Covariance: at the final pose, H = sum over final inliers of J^T J with the
// whitened residuals (no robust weights), J the Jacobian for a left
// perturbation of T_cam_world; H^-1 is carried to a left perturbation
// [translation; rotation] of T_world_cam (core/pose_estimate.hpp) with
// left_covariance_of_inverse(). It is the Gauss-Newton (Cramer-Rao)
// covariance for pixel noise of exactly the assumed sigmas.
//
// Solver: a Levenberg-Marquardt on the 6 unknowns written here, which follows
// Ceres's trust-region LM (its default radius, Jacobi scaling and stopping
// tolerances) step for step but without Ceres's per-residual virtual calls
// and problem set-up: the same poses, about 3x faster (docs/tracking/
// extraction.md, "The motion-only BA by hand"). Ceres stays the reference
// in motion_only_ba_test.
//
// Threads: solve() is const and keeps its state on the stack, so one
// MotionOnlyBa may be used from several threads.

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::optim {

// Below this many inliers a round is not run (ORB-SLAM2 PoseOptimization
// stops at fewer than 10 edges); the pose then stays where it is.
inline constexpr int kMinObservationsToOptimise = 10;

struct PoseObservation {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  // fixed map point, world frame (m)
  Eigen::Vector2d uv_left_px = Eigen::Vector2d::Zero();
  double u_right_px = -1.0;  // right-image column of the stereo match; < 0 = monocular
  double sigma2_px2 = 1.0;   // variance of the keypoint's level, level_sigma2_px2() (> 0)

  bool is_stereo() const { return u_right_px >= 0.0; }
};

struct MotionBaResult {
  SE3 T_cam_world;                   // optimised pose
  std::vector<std::uint8_t> inlier;  // per input observation: 1 = inlier after the last round
  std::vector<double> chi2;          // per observation at the final pose; +inf when behind the camera
  int num_inliers = 0;
  int num_inliers_stereo = 0;
  int num_inliers_mono = 0;
  double chi2_inlier_sum = 0.0;  // sum of chi2 over the final inliers
  double chi2_inlier_max = 0.0;
  // A-posteriori variance factor: chi2_inlier_sum / (inlier residuals - 6).
  // ~1 when the observations are as noisy as sigma2_px2 says; the Hessian
  // covariance below is NOT scaled by it (callers decide). 1 when there are
  // too few residuals to tell.
  double variance_factor = 1.0;
  int rounds_run = 0;  // rounds actually optimised (fewer when inliers ran short)
  int iterations = 0;  // LM iterations over all rounds
  // Left perturbation [translation; rotation] of T_world_cam (m^2, rad^2);
  // nullopt when the inliers do not constrain all 6 degrees of freedom.
  std::optional<Matrix6d> covariance_world_cam;

  SE3 T_world_cam() const { return T_cam_world.inverse(); }
};

class MotionOnlyBa {
 public:
  // Reads motion_ba_rounds, motion_ba_iterations, chi2_mono, chi2_stereo.
  MotionOnlyBa(const StereoCamera& camera, const config::TrackingConfig& tracking);

  // T_cam_world_init: the predicted pose (e.g. constant-velocity model).
  // Errors (kInvalidArgument): a non-finite value or sigma2_px2 <= 0, naming
  // the observation index. Few or no inliers is not an error: the result says
  // how many there are and the caller decides the tracking state.
  Expected<MotionBaResult> solve(const SE3& T_cam_world_init,
                                 std::span<const PoseObservation> observations) const;

  // Per observation: 1 when it passes the chi^2 gate at the fixed pose
  // T_cam_world (in front of the camera, chi2 <= chi2_mono / chi2_stereo),
  // nothing optimised. Same errors as solve().
  Expected<std::vector<std::uint8_t>> inliers_at(const SE3& T_cam_world,
                                                 std::span<const PoseObservation> observations) const;

 private:
  StereoCamera camera_;
  int rounds_;
  int iterations_per_round_;
  double chi2_mono_;
  double chi2_stereo_;
};

}  // namespace sitepose::optim
