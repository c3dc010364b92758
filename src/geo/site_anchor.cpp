#include "sitepose/geo/site_anchor.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "sitepose/core/enum_names.hpp"

namespace sitepose::geo {

namespace {

Status out_of_range(const char* key, double value, const char* rule) {
  return make_error(ErrorCode::kInvalidArgument,
                    fmt::format("site anchor option {} = {}: {}", key, value, rule));
}

// Std of the points along their second principal axis: how far they are from
// lying on a line (the rotation about that line is unobservable otherwise).
double lateral_spread_m(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 3) return 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) cov += (p - mean) * (p - mean).transpose();
  cov /= static_cast<double>(points.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  return std::sqrt(std::max(eig.eigenvalues()(1), 0.0));  // ascending order
}

}  // namespace

Status SiteAnchorOptions::validate() const {
  SITEPOSE_TRY_STATUS(validate_geodetic(origin, "site anchor origin"));
  if (!p_cam_antenna_m.allFinite()) {
    return make_error(ErrorCode::kInvalidArgument, "site anchor option p_cam_antenna_m: not finite");
  }
  if (max_pose_gap_ns <= 0) return out_of_range("max_pose_gap_ns", max_pose_gap_ns, "must be > 0");
  if (pose_history_ns < max_pose_gap_ns) {
    return out_of_range("pose_history_ns", pose_history_ns, "must be >= max_pose_gap_ns");
  }
  if (max_fix_wait_ns < 0) return out_of_range("max_fix_wait_ns", max_fix_wait_ns, "must be >= 0");
  if (!(min_pair_distance_m >= 0.0)) {
    return out_of_range("min_pair_distance_m", min_pair_distance_m, "must be >= 0");
  }
  if (min_inliers < 3) return out_of_range("min_inliers", min_inliers, "must be >= 3");
  if (max_pairs < min_inliers) return out_of_range("max_pairs", max_pairs, "must be >= min_inliers");
  if (!(min_inlier_ratio > 0.0 && min_inlier_ratio <= 1.0)) {
    return out_of_range("min_inlier_ratio", min_inlier_ratio, "must be in (0, 1]");
  }
  if (!(min_lateral_spread_m >= 0.0)) {
    return out_of_range("min_lateral_spread_m", min_lateral_spread_m, "must be >= 0");
  }
  if (refit_every_pairs < 1) return out_of_range("refit_every_pairs", refit_every_pairs, "must be >= 1");
  if (!(alignment.inlier_threshold_m > 0.0)) {
    return out_of_range("alignment.inlier_threshold_m", alignment.inlier_threshold_m, "must be > 0");
  }
  if (alignment.ransac_iterations < 1) {
    return out_of_range("alignment.ransac_iterations", alignment.ransac_iterations, "must be >= 1");
  }
  if (alignment.max_refits < 0) {
    return out_of_range("alignment.max_refits", alignment.max_refits, "must be >= 0");
  }
  if (freeze_inliers < min_inliers) {
    return out_of_range("freeze_inliers", freeze_inliers, "must be >= min_inliers");
  }
  if (!(freeze_lateral_spread_m >= min_lateral_spread_m)) {
    return out_of_range("freeze_lateral_spread_m", freeze_lateral_spread_m,
                        "must be >= min_lateral_spread_m");
  }
  return ok_status();
}

constexpr auto kAnchorStateNames = enum_names<AnchorState>({{AnchorState::kCollecting, "collecting"},
                                                            {AnchorState::kEstimating, "estimating"},
                                                            {AnchorState::kFrozen, "frozen"}},
                                                           "unknown");

const char* to_string(AnchorState state) { return kAnchorStateNames.name(state); }

Expected<SiteAnchor> SiteAnchor::create(const SiteAnchorOptions& options) {
  SITEPOSE_TRY_STATUS(options.validate());
  SITEPOSE_TRY(LocalEnu enu, LocalEnu::create(options.origin));
  return SiteAnchor(options, std::move(enu));
}

void SiteAnchor::reset() {
  poses_.clear();
  pending_.clear();
  newest_fix_t_ns_ = 0;
  p_slam_.clear();
  p_site_.clear();
  pairs_at_last_fit_ = 0;
  status_ = AnchorStatus{};
  site_frame_.reset();
}

void SiteAnchor::add_slam_pose(std::int64_t t_ns, const SE3& T_slam_cam) {
  if (status_.state == AnchorState::kFrozen) return;
  if (!poses_.empty() && t_ns <= poses_.back().t_ns) return;
  poses_.push_back({t_ns, T_slam_cam});
  while (!poses_.empty() && poses_.front().t_ns < t_ns - options_.pose_history_ns) {
    poses_.pop_front();
  }
  process_pending();
}

void SiteAnchor::add_fix(const GnssFix& fix) {
  ++status_.fixes_received;
  if (status_.state == AnchorState::kFrozen) {
    ++status_.fixes_after_freeze;
    return;
  }
  GnssFix shifted = fix;
  shifted.t_ns = fix.t_ns + options_.gnss_clock_offset_ns;
  newest_fix_t_ns_ = std::max(newest_fix_t_ns_, shifted.t_ns);
  // Keep time order even if a transport reorders.
  auto it = std::upper_bound(pending_.begin(), pending_.end(), shifted.t_ns,
                             [](std::int64_t t, const GnssFix& f) { return t < f.t_ns; });
  pending_.insert(it, shifted);
  process_pending();
}

std::optional<SE3> SiteAnchor::pose_at(std::int64_t t_ns) const {
  if (poses_.empty() || t_ns < poses_.front().t_ns || t_ns > poses_.back().t_ns) {
    return std::nullopt;
  }
  auto after = std::lower_bound(poses_.begin(), poses_.end(), t_ns,
                                [](const StampedPose& p, std::int64_t t) { return p.t_ns < t; });
  if (after->t_ns == t_ns) return after->T_slam_cam;
  const auto before = std::prev(after);
  const std::int64_t gap_ns = after->t_ns - before->t_ns;
  if (gap_ns > options_.max_pose_gap_ns) return std::nullopt;
  const double alpha = static_cast<double>(t_ns - before->t_ns) / static_cast<double>(gap_ns);
  return interpolate(before->T_slam_cam, after->T_slam_cam, alpha);
}

void SiteAnchor::process_pending() {
  while (!pending_.empty() && status_.state != AnchorState::kFrozen) {
    const GnssFix& fix = pending_.front();
    const bool good =
        fix.has_position() && static_cast<int>(fix.quality) == static_cast<int>(options_.required_quality);
    if (!good) {
      // Needs no pose: handled as soon as every earlier fix is.
      ++status_.fixes_low_quality;
      // The pairs since the last fit count too: fit them before freezing.
      if (status_.pairs > pairs_at_last_fit_) refit();
      if (status_.state == AnchorState::kFrozen) {
        pending_.clear();
        return;
      }
      if (site_frame_) {
        freeze(fmt::format("GNSS quality dropped to {} at t_ns {}", to_string(fix.quality), fix.t_ns));
        pending_.clear();
        return;
      }
      pending_.pop_front();
      continue;
    }
    const bool pose_later_exists = !poses_.empty() && poses_.back().t_ns >= fix.t_ns;
    if (!pose_later_exists) {
      // Wait for the camera to catch up, but not forever (tracking may be lost).
      if (newest_fix_t_ns_ - fix.t_ns <= options_.max_fix_wait_ns) return;
      ++status_.fixes_unmatched;
      pending_.pop_front();
      continue;
    }
    const std::optional<SE3> T_slam_cam = pose_at(fix.t_ns);
    if (!T_slam_cam) {
      ++status_.fixes_unmatched;
      pending_.pop_front();
      continue;
    }
    const Eigen::Vector3d p_slam = *T_slam_cam * options_.p_cam_antenna_m;
    const Eigen::Vector3d p_site = enu_.to_enu(fix.position);
    pending_.pop_front();
    if (!p_site_.empty() && (p_site - p_site_.back()).norm() < options_.min_pair_distance_m) {
      ++status_.fixes_standstill;
      continue;
    }
    add_pair(p_slam, p_site);
  }
}

void SiteAnchor::add_pair(const Eigen::Vector3d& p_slam_antenna, const Eigen::Vector3d& p_site_antenna) {
  p_slam_.push_back(p_slam_antenna);
  p_site_.push_back(p_site_antenna);
  if (static_cast<int>(p_slam_.size()) > options_.max_pairs) {
    p_slam_.erase(p_slam_.begin());
    p_site_.erase(p_site_.begin());
    --pairs_at_last_fit_;
  }
  status_.pairs = static_cast<int>(p_slam_.size());
  const bool first_try = !site_frame_ && status_.pairs >= options_.min_inliers;
  if (status_.pairs - pairs_at_last_fit_ >= options_.refit_every_pairs ||
      (first_try && pairs_at_last_fit_ == 0)) {
    refit();
  }
}

void SiteAnchor::refit() {
  pairs_at_last_fit_ = status_.pairs;
  if (status_.pairs < options_.min_inliers) return;
  auto fit = robust_umeyama_se3(p_slam_, p_site_, options_.alignment);
  if (!fit) return;  // no consistent subset yet: keep collecting
  std::vector<Eigen::Vector3d> inliers_site;
  for (std::size_t i = 0; i < p_site_.size(); ++i) {
    if (fit->inlier[i]) inliers_site.push_back(p_site_[i]);
  }
  const double spread_m = lateral_spread_m(inliers_site);
  const double ratio = static_cast<double>(fit->num_inliers) / status_.pairs;
  if (fit->num_inliers < options_.min_inliers || ratio < options_.min_inlier_ratio ||
      spread_m < options_.min_lateral_spread_m) {
    return;  // the previous estimate, if any, stays
  }
  auto frame = SiteFrame::create(options_.origin, fit->T_dst_src, options_.forward_axis_cam);
  if (!frame) return;  // cannot happen: origin validated in create()
  site_frame_ = std::move(*frame);
  status_.inliers = fit->num_inliers;
  status_.inlier_rms_m = fit->inlier_rms_m;
  status_.lateral_spread_m = spread_m;
  status_.state = AnchorState::kEstimating;
  if (fit->num_inliers >= options_.freeze_inliers && spread_m >= options_.freeze_lateral_spread_m) {
    freeze(fmt::format("{} inliers spread {:.2f} m laterally", fit->num_inliers, spread_m));
  }
}

void SiteAnchor::freeze(std::string reason) {
  status_.state = AnchorState::kFrozen;
  status_.freeze_reason = std::move(reason);
}

}  // namespace sitepose::geo
