#include "sitepose/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace sitepose::eval {

ErrorStats compute_stats(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    s.rmse = s.mean = s.median = s.std = s.min = s.max = nan;
    return s;
  }
  const double n = static_cast<double>(errors.size());
  double sum = 0.0;
  double sum_sq = 0.0;
  for (const double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (const double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const std::size_t mid = sorted.size() / 2;
  s.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

namespace {

// Index into `pairs` of the partner of pairs[k] per the gap spec, or -1.
long partner_index(const io::Trajectory& gt, const std::vector<AssociatedPair>& pairs,
                   std::size_t k, const RpeSpec& spec) {
  if (spec.kind == RpeGapKind::kFrames) {
    const std::size_t target = pairs[k].gt_index + static_cast<std::size_t>(spec.delta_frames);
    const auto it = std::lower_bound(
        pairs.begin() + static_cast<long>(k), pairs.end(), target,
        [](const AssociatedPair& p, std::size_t v) { return p.gt_index < v; });
    if (it == pairs.end() || it->gt_index != target) return -1;
    return it - pairs.begin();
  }
  const double target_t = gt[pairs[k].gt_index].t_s + spec.delta_time_s;
  const auto it = std::lower_bound(
      pairs.begin() + static_cast<long>(k) + 1, pairs.end(), target_t,
      [&gt](const AssociatedPair& p, double v) { return gt[p.gt_index].t_s < v; });
  // The nearest in time is `it` (first at or after the target) or the one
  // before it, provided that one still lies after pairs[k].
  long best = -1;
  double best_err = std::numeric_limits<double>::infinity();
  if (it != pairs.end()) {
    best = it - pairs.begin();
    best_err = std::abs(gt[it->gt_index].t_s - target_t);
  }
  if (it - pairs.begin() > static_cast<long>(k) + 1) {
    const auto prev = std::prev(it);
    const double err = std::abs(gt[prev->gt_index].t_s - target_t);
    if (err < best_err) {
      best_err = err;
      best = prev - pairs.begin();
    }
  }
  if (best < 0 || best_err > spec.time_tolerance_s) return -1;
  return best;
}

}  // namespace

RpeResult compute_rpe(const io::Trajectory& gt, const io::Trajectory& est,
                      const std::vector<AssociatedPair>& pairs, const RpeSpec& spec) {
  RpeResult result;
  result.spec = spec;
  std::vector<double> trans_m;
  std::vector<double> rot_deg;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const long m = partner_index(gt, pairs, k, spec);
    if (m < 0) continue;
    const AssociatedPair& a = pairs[k];
    const AssociatedPair& b = pairs[static_cast<std::size_t>(m)];
    const SE3 gt_rel = gt[a.gt_index].T_world_cam.inverse() * gt[b.gt_index].T_world_cam;
    const SE3 est_rel = est[a.est_index].T_world_cam.inverse() * est[b.est_index].T_world_cam;
    const SE3 error = gt_rel.inverse() * est_rel;
    trans_m.push_back(error.translation().norm());
    rot_deg.push_back(rotation_angle_rad(error.rotation()) * 180.0 / std::numbers::pi);
  }
  result.translation_m = compute_stats(trans_m);
  result.rotation_deg = compute_stats(rot_deg);
  return result;
}

}  // namespace sitepose::eval
