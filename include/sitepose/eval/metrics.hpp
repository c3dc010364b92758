#pragma once
// Error statistics, absolute trajectory error and relative pose error
// (FORMATS.md "Evaluation conventions"). Pure computation.

#include <cstddef>
#include <vector>

#include "sitepose/core/se3.hpp"
#include "sitepose/eval/association.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::eval {

// Summary of a set of non-negative errors. With count == 0 every figure is
// NaN (written as null in JSON).
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;  // population standard deviation (evo's "std")
  double min = 0.0;
  double max = 0.0;
};

ErrorStats compute_stats(const std::vector<double>& errors);

// How the second pose of an RPE pair is chosen.
enum class RpeGapKind {
  kTime,    // ground-truth time t_i + delta_time_s (nearest associated pose)
  kFrames,  // ground-truth frame index i + delta_frames
};

struct RpeSpec {
  RpeGapKind kind = RpeGapKind::kTime;
  double delta_time_s = 1.0;
  int delta_frames = 10;
  // kTime only: the pair is used when its ground-truth time gap is within
  // delta_time_s +- time_tolerance_s (covers frame jitter and lost frames).
  double time_tolerance_s = 0.1;
};

struct RpeResult {
  RpeSpec spec;
  ErrorStats translation_m;  // |translation of E|
  ErrorStats rotation_deg;   // angle of E
};

// RPE over associated pairs: for each pair (i, j) chosen by `spec`,
// E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with Q ground truth and P estimate
// (T_world_cam). Invariant to any rigid alignment of the estimate, so it is
// computed on the raw estimate. `pairs` must be sorted by gt_index (as
// associate() returns them).
RpeResult compute_rpe(const io::Trajectory& gt, const io::Trajectory& est,
                      const std::vector<AssociatedPair>& pairs, const RpeSpec& spec);

}  // namespace sitepose::eval
