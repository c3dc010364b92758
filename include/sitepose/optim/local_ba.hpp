#pragma once
// Local bundle adjustment (ORB-SLAM2 Optimizer::LocalBundleAdjustment) on
// plain inputs, independent of the map data structures: keyframe poses (some
// held fixed, e.g. the outer ring of covisible keyframes), world points and
// their mono / stereo observations.
//
// Two stages: (1) Huber-robust optimisation for half of local_ba_iterations
// (at least 1); observations with chi^2 above the gate (chi2_mono /
// chi2_stereo) or with the point not in front of the camera are dropped;
// (2) optimisation of the rest without the robust kernel for
// local_ba_iterations. ORB-SLAM2 runs 5 then 10. Afterwards every
// observation is tested again at the final estimate and the failing ones are
// returned as outliers (the mapper erases them from the map).
//
// Solver: Levenberg-Marquardt with the Schur complement, points eliminated
// first (DENSE_SCHUR up to 40 free keyframes, SPARSE_SCHUR beyond); Ceres
// single-threaded. Poses use Se3LeftManifold (7-double T_cam_world).
// Fixed keyframes are constant parameter blocks: their poses come back bit
// for bit as given. Without any fixed keyframe the 6-dof gauge is free
// (Levenberg-Marquardt damping keeps it bounded); the mapper should fix at
// least the oldest keyframe.
//
// Stop flag: when *stop becomes true (checked before each stage and after
// every iteration), the solve ends at the last accepted iterate, which is
// returned with aborted = true; it is still an improvement on the input.
// Threads: solve() is const and owns its problem; `stop` may be written by
// another thread while solve() runs.

#include <atomic>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::optim {

struct LocalBaObservation {
  int keyframe_index = 0;  // into LocalBaInput::T_cam_world
  int point_index = 0;     // into LocalBaInput::p_world
  Eigen::Vector2d uv_left_px = Eigen::Vector2d::Zero();
  double u_right_px = -1.0;  // < 0 = monocular
  double sigma2_px2 = 1.0;   // level variance, > 0

  bool is_stereo() const { return u_right_px >= 0.0; }
};

struct LocalBaInput {
  std::vector<SE3> T_cam_world;              // per keyframe
  std::vector<std::uint8_t> keyframe_fixed;  // per keyframe, 1 = held constant
  std::vector<Eigen::Vector3d> p_world;      // per point (m)
  std::vector<LocalBaObservation> observations;
};

struct LocalBaResult {
  std::vector<SE3> T_cam_world;          // same order as the input
  std::vector<Eigen::Vector3d> p_world;  // same order as the input
  // Indices into LocalBaInput::observations that fail the chi^2 / depth test
  // at the returned estimate, ascending.
  std::vector<int> outlier_observations;
  bool aborted = false;     // the stop flag ended the solve early
  int stages_run = 0;       // 0, 1 or 2
  int iterations = 0;       // LM iterations over both stages
  double initial_cost = 0.0;  // 0.5 sum chi^2 of stage 1 at its start (robustified)
  double final_cost = 0.0;    // 0.5 sum chi^2 of the last stage at its end
};

class LocalBa {
 public:
  // Reads mapping.local_ba_iterations and tracking.chi2_mono / chi2_stereo.
  LocalBa(const StereoCamera& camera, const config::MappingConfig& mapping,
          const config::TrackingConfig& tracking);

  // Errors (kInvalidArgument): size mismatch of keyframe_fixed, an index out
  // of range, non-finite input or sigma2_px2 <= 0 (naming the entry).
  // `stop` may be null.
  Expected<LocalBaResult> solve(const LocalBaInput& input, const std::atomic<bool>* stop) const;

 private:
  StereoCamera camera_;
  int stage1_iterations_;
  int stage2_iterations_;
  double chi2_mono_;
  double chi2_stereo_;
};

}  // namespace sitepose::optim
