#pragma once
// Trajectory evaluation as FORMATS.md "Evaluation conventions" defines it:
// associate by timestamp, optionally search a constant time offset, align
// with SE(3) Umeyama (no scale), then ATE, RPE (1 s and 10 frames) and
// coverage. Pure computation: the caller reads files and writes outputs.

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/eval/association.hpp"
#include "sitepose/eval/metrics.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::eval {

struct EvalOptions {
  double max_dt_s = kDefaultMaxDtS;
  // 0 = use time_offset_s as given; > 0 = search [-range, +range].
  double time_offset_search_range_s = 0.0;
  double time_offset_s = 0.0;  // t_gt = t_est + time_offset_s, when not searched
  RpeSpec rpe_time{RpeGapKind::kTime, 1.0, 10, 0.1};
  RpeSpec rpe_frames{RpeGapKind::kFrames, 1.0, 10, 0.1};
};

// One associated pose after alignment.
struct PoseError {
  std::size_t gt_index = 0;
  std::size_t est_index = 0;
  double t_gt_s = 0.0;
  Eigen::Vector3d p_gt_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_est_aligned_m = Eigen::Vector3d::Zero();  // T_gt_est * p_est
  double error_m = 0.0;
};

struct EvalResult {
  std::size_t gt_frames = 0;
  std::size_t est_poses = 0;
  std::size_t associated = 0;
  double coverage = 0.0;  // associated / gt_frames
  double max_dt_s = kDefaultMaxDtS;
  bool time_offset_searched = false;
  double time_offset_search_range_s = 0.0;
  double time_offset_s = 0.0;  // used for the association: t_gt = t_est + offset
  SE3 T_gt_est;                // aligns the estimate's world to the ground truth's
  ErrorStats ate_m;
  RpeResult rpe_time;
  RpeResult rpe_frames;
  std::vector<PoseError> poses;  // sorted by gt_index
};

// Fails (kInvalidArgument) on an empty trajectory, non-increasing or
// non-finite timestamps, bad options (max_dt_s <= 0, negative range), fewer
// than 3 associated poses; each message says which and what was expected.
Expected<EvalResult> evaluate(const io::Trajectory& gt, const io::Trajectory& est,
                              const EvalOptions& options);

// JSON object with every summary figure (NaN -> null). Per-pose errors are
// included only when include_poses is set (they can be large).
std::string to_json(const EvalResult& result, bool include_poses = false);

// Human-readable multi-line summary.
std::string to_text(const EvalResult& result);

}  // namespace sitepose::eval
