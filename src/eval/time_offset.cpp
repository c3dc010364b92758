#include "sitepose/eval/time_offset.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "sitepose/eval/alignment.hpp"
#include "sitepose/eval/association.hpp"

namespace sitepose::eval {
namespace {

constexpr double kRefineToleranceS = 1e-4;
constexpr int kMaxGridPoints = 4001;
// Ground-truth gaps wider than this many median periods are not interpolated
// (a pose there would be compared with a guess).
constexpr double kMaxGapPeriods = 3.0;

double median_period_s(const io::Trajectory& gt) {
  std::vector<double> dts;
  dts.reserve(gt.size());
  for (std::size_t i = 1; i < gt.size(); ++i) dts.push_back(gt[i].t_s - gt[i - 1].t_s);
  std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
  return dts[dts.size() / 2];
}

class OffsetObjective {
 public:
  OffsetObjective(const io::Trajectory& gt, std::vector<Eigen::Vector3d> p_est, std::vector<double> t_est,
                  double max_gap_s)
      : gt_(gt), p_est_(std::move(p_est)), t_est_(std::move(t_est)), max_gap_s_(max_gap_s) {}

  // Aligned position RMSE at this offset; +inf when fewer than 3 poses fall
  // on interpolable ground truth.
  double operator()(double offset_s) {
    ++evaluations_;
    src_.clear();
    dst_.clear();
    for (std::size_t j = 0; j < t_est_.size(); ++j) {
      const double t = t_est_[j] + offset_s;
      const auto it = std::lower_bound(gt_.begin(), gt_.end(), t,
                                       [](const io::StampedPose& p, double v) { return p.t_s < v; });
      if (it == gt_.end() || it == gt_.begin()) {
        if (it != gt_.end() && it->t_s == t) {
          src_.push_back(p_est_[j]);
          dst_.push_back(it->T_world_cam.translation());
        }
        continue;
      }
      const auto prev = std::prev(it);
      const double gap = it->t_s - prev->t_s;
      if (gap > max_gap_s_) continue;
      const double alpha = (t - prev->t_s) / gap;
      src_.push_back(p_est_[j]);
      dst_.push_back((1.0 - alpha) * prev->T_world_cam.translation() + alpha * it->T_world_cam.translation());
    }
    auto T = umeyama_se3(src_, dst_);
    if (!T) return std::numeric_limits<double>::infinity();
    double sum_sq = 0.0;
    for (std::size_t i = 0; i < src_.size(); ++i) sum_sq += (dst_[i] - (*T) * src_[i]).squaredNorm();
    return std::sqrt(sum_sq / static_cast<double>(src_.size()));
  }

  int evaluations() const { return evaluations_; }

 private:
  const io::Trajectory& gt_;
  std::vector<Eigen::Vector3d> p_est_;
  std::vector<double> t_est_;
  double max_gap_s_;
  std::vector<Eigen::Vector3d> src_;
  std::vector<Eigen::Vector3d> dst_;
  int evaluations_ = 0;
};

// The best offset on a grid over [-range_s, range_s]: half a period
// resolves the basin of the true offset (the objective varies on the scale
// of the motion, not of the sampling). `step_s` returns the grid step.
std::pair<double, double> grid_search(OffsetObjective& objective, double range_s, double period_s,
                                      double& step_s) {
  step_s = 0.5 * period_s;
  int half_steps = static_cast<int>(std::ceil(range_s / step_s));
  if (2 * half_steps + 1 > kMaxGridPoints) {
    half_steps = (kMaxGridPoints - 1) / 2;
    step_s = range_s / half_steps;
  }
  double best_offset = 0.0;
  double best_value = std::numeric_limits<double>::infinity();
  for (int k = -half_steps; k <= half_steps; ++k) {
    const double offset = std::clamp(k * step_s, -range_s, range_s);
    const double value = objective(offset);
    if (value < best_value) {
      best_value = value;
      best_offset = offset;
    }
  }
  return {best_offset, best_value};
}

// Golden-section search for the minimum within [a, b], to kRefineToleranceS.
double golden_section_minimum(OffsetObjective& objective, double a, double b) {
  constexpr double kInvPhi = 0.6180339887498949;
  double c = b - kInvPhi * (b - a);
  double d = a + kInvPhi * (b - a);
  double fc = objective(c);
  double fd = objective(d);
  while (b - a > kRefineToleranceS) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - kInvPhi * (b - a);
      fc = objective(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + kInvPhi * (b - a);
      fd = objective(d);
    }
  }
  return 0.5 * (a + b);
}

}  // namespace

Expected<TimeOffsetResult> search_time_offset(const io::Trajectory& gt, const io::Trajectory& est,
                                              double range_s) {
  if (!std::isfinite(range_s) || range_s <= 0.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("time offset search range = {} s: must be a finite value > 0", range_s));
  }
  SITEPOSE_TRY_STATUS(check_timestamps(gt, "ground-truth"));
  SITEPOSE_TRY_STATUS(check_timestamps(est, "estimated"));
  if (gt.size() < 3) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("time offset search: ground truth has {} poses; at least 3 "
                                  "are needed",
                                  gt.size()));
  }
  // Fixed set of estimate poses: inside the ground truth for every offset.
  const double t_lo = gt.front().t_s + range_s;
  const double t_hi = gt.back().t_s - range_s;
  std::vector<Eigen::Vector3d> p_est;
  std::vector<double> t_est;
  for (const auto& p : est) {
    if (p.t_s >= t_lo && p.t_s <= t_hi) {
      p_est.push_back(p.T_world_cam.translation());
      t_est.push_back(p.t_s);
    }
  }
  if (p_est.size() < 3) {
    return make_error(
        ErrorCode::kInvalidArgument,
        fmt::format("time offset search over +-{} s: only {} estimated poses lie at least {} s "
                    "inside the ground truth ({:.3f} .. {:.3f} s); at least 3 are needed: use a "
                    "smaller range",
                    range_s, p_est.size(), range_s, gt.front().t_s, gt.back().t_s));
  }
  const double period_s = median_period_s(gt);
  OffsetObjective objective(gt, std::move(p_est), std::move(t_est), kMaxGapPeriods * period_s);

  double step_s = 0.0;
  const auto [best_offset, best_value] = grid_search(objective, range_s, period_s, step_s);
  if (!std::isfinite(best_value)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "time offset search: no offset in range puts 3 estimated poses on "
                      "interpolable ground truth (gaps wider than 3 frame periods)");
  }
  // Refined within one grid step either side.
  const double refined = golden_section_minimum(objective, std::max(-range_s, best_offset - step_s),
                                                std::min(range_s, best_offset + step_s));
  const double refined_value = objective(refined);
  TimeOffsetResult result;
  if (refined_value <= best_value) {
    result.time_offset_s = refined;
    result.ate_rmse_m = refined_value;
  } else {
    result.time_offset_s = best_offset;
    result.ate_rmse_m = best_value;
  }
  result.evaluations = objective.evaluations();
  return result;
}

}  // namespace sitepose::eval
