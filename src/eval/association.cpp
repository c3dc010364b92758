#include "sitepose/eval/association.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

namespace sitepose::eval {

Status check_timestamps(const io::Trajectory& trajectory, const char* name) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const double t = trajectory[i].t_s;
    if (!std::isfinite(t)) {
      return make_error(ErrorCode::kInvalidArgument,
                        fmt::format("{} trajectory: pose {} has a non-finite timestamp", name, i));
    }
    if (i > 0 && !(t > trajectory[i - 1].t_s)) {
      return make_error(ErrorCode::kInvalidArgument,
                        fmt::format("{} trajectory: timestamps must increase strictly, but pose {} "
                                    "has t = {:.9f} s after t = {:.9f} s",
                                    name, i, t, trajectory[i - 1].t_s));
    }
  }
  return ok_status();
}

namespace {

// Index of the element of `gt` nearest in time to t (gt non-empty, sorted).
std::size_t nearest_index(const io::Trajectory& gt, double t) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t,
                                   [](const io::StampedPose& p, double v) { return p.t_s < v; });
  if (it == gt.begin()) return 0;
  if (it == gt.end()) return gt.size() - 1;
  const auto prev = std::prev(it);
  return (t - prev->t_s) <= (it->t_s - t) ? static_cast<std::size_t>(prev - gt.begin())
                                          : static_cast<std::size_t>(it - gt.begin());
}

}  // namespace

std::vector<AssociatedPair> associate(const io::Trajectory& gt, const io::Trajectory& est,
                                      double max_dt_s, double time_offset_s) {
  std::vector<AssociatedPair> candidates;
  if (gt.empty() || est.empty()) return candidates;
  // Candidates: each estimate's nearest ground truth. Greedy acceptance by
  // increasing |dt| then makes the matching one-to-one with the closest
  // pairs kept (a second estimate near an already taken ground-truth pose is
  // dropped rather than matched to a farther one beyond the nearest).
  candidates.reserve(est.size());
  for (std::size_t j = 0; j < est.size(); ++j) {
    const double t = est[j].t_s + time_offset_s;
    const std::size_t i = nearest_index(gt, t);
    const double dt = gt[i].t_s - t;
    if (std::abs(dt) <= max_dt_s) candidates.push_back({i, j, dt});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const AssociatedPair& a, const AssociatedPair& b) {
                     return std::abs(a.dt_s) < std::abs(b.dt_s);
                   });
  std::vector<char> gt_used(gt.size(), 0);
  std::vector<AssociatedPair> pairs;
  pairs.reserve(candidates.size());
  for (const auto& c : candidates) {
    if (gt_used[c.gt_index]) continue;
    gt_used[c.gt_index] = 1;
    pairs.push_back(c);
  }
  std::sort(pairs.begin(), pairs.end(), [](const AssociatedPair& a, const AssociatedPair& b) {
    return a.gt_index < b.gt_index;
  });
  return pairs;
}

}  // namespace sitepose::eval
