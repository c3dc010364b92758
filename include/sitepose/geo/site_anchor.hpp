#pragma once
// Online estimation of T_site_slam from GNSS fixes received while RTK is
// good, then frozen.
//
// Each RTK-fixed GNSS fix (antenna position, converted to the site ENU frame
// at the origin) is paired with the antenna position predicted by SLAM at the
// fix time: T_slam_cam interpolated between the two SLAM poses around it
// (core::interpolate), applied to the lever arm p_cam_antenna. T_site_slam
// is the rigid Umeyama fit (no scale) of these pairs with RANSAC + trimming
// (robust_alignment.hpp). Life cycle:
//   kCollecting  no usable estimate yet (too few inliers, or the points are
//                too close to a line for the rotation to be observable);
//   kEstimating  site_frame() holds the latest fit, refined as pairs arrive;
//   kFrozen      site_frame() is fixed: RTK dropped (a fix of lower quality
//                than required arrived after an estimate existed), or enough
//                well-spread inliers were collected. Only reset() unfreezes.
// A drop of RTK before any estimate exists does not freeze: the pairs
// already collected are kept and collection resumes when RTK returns.
//
// Time: fixes carry UTC (GnssFix::t_ns); t_camera = t_fix +
// gnss_clock_offset_ns must be on the clock of the SLAM poses.
// Threads: not thread-safe; owned and called by one thread (the daemon's
// publish stage). Call reset() when the SLAM world frame changes (new map).

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/geo/geodetic.hpp"
#include "sitepose/geo/gnss_fix.hpp"
#include "sitepose/geo/robust_alignment.hpp"
#include "sitepose/geo/site_frame.hpp"

namespace sitepose::geo {

struct SiteAnchorOptions {
  Geodetic origin;                    // of the site ENU frame
  ForwardAxis forward_axis_cam = ForwardAxis::kMinusX;
  // GNSS antenna phase centre in the left camera frame (translation of
  // T_cam_antenna), m.
  Eigen::Vector3d p_cam_antenna_m = Eigen::Vector3d::Zero();
  std::int64_t gnss_clock_offset_ns = 0;  // t_camera = t_fix + offset
  GnssQuality required_quality = GnssQuality::kRtkFixed;

  // Association.
  std::int64_t max_pose_gap_ns = 250'000'000;   // SLAM poses around a fix at most this far apart
  std::int64_t pose_history_ns = 10'000'000'000;  // SLAM poses kept for late fixes
  std::int64_t max_fix_wait_ns = 2'000'000'000;   // a fix waits this long for a later SLAM pose
  double min_pair_distance_m = 0.05;  // skip a fix this close to the previous pair (standstill)
  int max_pairs = 3000;               // oldest pairs dropped beyond this

  // Estimation.
  int min_inliers = 20;               // before a first estimate
  double min_inlier_ratio = 0.5;
  double min_lateral_spread_m = 1.0;  // std of the inliers along their 2nd principal axis
  int refit_every_pairs = 10;
  RobustAlignmentOptions alignment;

  // Freezing when the estimate is good enough (besides RTK loss).
  int freeze_inliers = 300;
  double freeze_lateral_spread_m = 5.0;

  // Names the first field out of range.
  Status validate() const;
};

enum class AnchorState { kCollecting, kEstimating, kFrozen };
const char* to_string(AnchorState state);

struct AnchorStatus {
  AnchorState state = AnchorState::kCollecting;
  std::int64_t fixes_received = 0;
  std::int64_t fixes_low_quality = 0;   // below required_quality (or no position)
  std::int64_t fixes_unmatched = 0;     // no SLAM poses around them in time
  std::int64_t fixes_standstill = 0;    // skipped by min_pair_distance_m
  std::int64_t fixes_after_freeze = 0;  // ignored once frozen
  int pairs = 0;
  int inliers = 0;
  double inlier_rms_m = 0.0;
  double lateral_spread_m = 0.0;
  std::string freeze_reason;            // empty unless frozen
};

class SiteAnchor {
 public:
  static Expected<SiteAnchor> create(const SiteAnchorOptions& options);

  // A SLAM pose of the left camera, only while tracking is OK, in time
  // order (an older or equal t_ns is ignored).
  void add_slam_pose(std::int64_t t_ns, const SE3& T_slam_cam);
  // A receiver fix, in time order.
  void add_fix(const GnssFix& fix);

  AnchorState state() const { return status_.state; }
  const AnchorStatus& status() const { return status_; }
  // Set in kEstimating and kFrozen.
  const std::optional<SiteFrame>& site_frame() const { return site_frame_; }
  // Drops all poses, fixes and the estimate; back to kCollecting.
  void reset();

 private:
  explicit SiteAnchor(const SiteAnchorOptions& options, LocalEnu enu)
      : options_(options), enu_(std::move(enu)) {}

  struct StampedPose {
    std::int64_t t_ns;
    SE3 T_slam_cam;
  };

  void process_pending();
  // Interpolated T_slam_cam at t_ns; nullopt when not bracketed closely.
  std::optional<SE3> pose_at(std::int64_t t_ns) const;
  void add_pair(const Eigen::Vector3d& p_slam_antenna, const Eigen::Vector3d& p_site_antenna);
  void refit();
  void freeze(std::string reason);

  SiteAnchorOptions options_;
  LocalEnu enu_;
  std::deque<StampedPose> poses_;        // increasing t_ns
  std::deque<GnssFix> pending_;          // t_ns on the camera clock, increasing
  std::int64_t newest_fix_t_ns_ = 0;
  std::vector<Eigen::Vector3d> p_slam_;  // antenna positions predicted by SLAM
  std::vector<Eigen::Vector3d> p_site_;  // antenna positions from the fixes
  int pairs_at_last_fit_ = 0;
  AnchorStatus status_;
  std::optional<SiteFrame> site_frame_;
};

}  // namespace sitepose::geo
