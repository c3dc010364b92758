#pragma once
// Constant clock offset between estimate and ground truth, chosen to minimise
// ATE (METHOD.md "Setting": the paper picks the GNSS/camera offset that
// minimises ATE). Pure computation.

#include "sitepose/core/expected.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::eval {

struct TimeOffsetResult {
  double time_offset_s = 0.0;  // t_gt = t_est + time_offset_s
  double ate_rmse_m = 0.0;     // objective at the optimum (interpolated GT)
  int evaluations = 0;         // objective evaluations spent
};

// Searches time_offset_s in [-range_s, +range_s]. The objective is the
// aligned (SE(3) Umeyama) position RMSE between estimate positions and the
// ground truth linearly interpolated at t_est + offset; interpolation makes
// it continuous in the offset, so a sub-frame offset is found. Only estimate
// poses whose shifted time stays inside the ground truth for every offset in
// the range are used, so the objective always averages the same poses;
// ground-truth gaps wider than 3 median frame periods are not interpolated.
// Coarse grid (step: half a median ground-truth period, at most 4001 points)
// then golden-section refinement around the best grid point to 1e-4 s.
// Fails (kInvalidArgument) for range_s <= 0 or not finite, fewer than 3
// usable poses (e.g. a range too large for the sequence), or bad timestamps.
Expected<TimeOffsetResult> search_time_offset(const io::Trajectory& gt, const io::Trajectory& est,
                                              double range_s);

}  // namespace sitepose::eval
