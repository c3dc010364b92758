#pragma once
// Timestamp association of an estimated trajectory with ground truth
// (FORMATS.md "Evaluation conventions"). Pure computation: no I/O, no
// threads; safe to call concurrently on distinct inputs.

#include <cstddef>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::eval {

// Default largest |t_gt - (t_est + offset)| of an associated pair (FORMATS.md).
inline constexpr double kDefaultMaxDtS = 0.02;

// One associated pair: indices into the ground-truth and estimate
// trajectories, and the residual time difference t_gt - (t_est + offset).
struct AssociatedPair {
  std::size_t gt_index = 0;
  std::size_t est_index = 0;
  double dt_s = 0.0;
};

// Fails (kInvalidArgument) when timestamps are not strictly increasing or not
// finite; the message names the trajectory (`name`), the index and the times.
Status check_timestamps(const io::Trajectory& trajectory, const char* name);

// Nearest-timestamp, one-to-one association. An estimate stamped t_est is
// compared with ground truth at t_est + time_offset_s (so a positive offset
// means the estimate's clock is behind the ground truth's). Each pose takes
// part in at most one pair; when two candidates compete for one pose, the
// smaller |dt| wins. Pairs with |dt| > max_dt_s are dropped. Both inputs must
// pass check_timestamps (not re-checked here). Result sorted by gt_index
// (and so also by est_index).
std::vector<AssociatedPair> associate(const io::Trajectory& gt, const io::Trajectory& est,
                                      double max_dt_s, double time_offset_s = 0.0);

}  // namespace sitepose::eval
