#include "sitepose/tracking/standing.hpp"

#include <algorithm>
#include <cmath>

namespace sitepose::tracking {

const char* to_string(StandingVerdict verdict) {
  switch (verdict) {
    case StandingVerdict::kNotStanding: return "not standing";
    case StandingVerdict::kStill: return "still";
    case StandingVerdict::kMoved: return "moved";
    case StandingVerdict::kHeld: return "held";
    case StandingVerdict::kUnsure: return "unsure";
  }
  return "?";
}

PoseDistance pose_distance(const SE3& T_cam_world_a, const SE3& T_cam_world_b) {
  const SE3 delta = T_cam_world_a * T_cam_world_b.inverse();
  PoseDistance d;
  // The camera centres: -R^T t of each pose.
  d.translation_m = (T_cam_world_a.inverse().translation() - T_cam_world_b.inverse().translation()).norm();
  d.rotation_rad = delta.rotation().angularDistance(Eigen::Quaterniond::Identity());
  return d;
}

bool TwoMotions::agree() const {
  return reestimate_valid && reestimate_inliers > 0 &&
         static_cast<double>(outside_moved_gate) / reestimate_inliers <= kAgreeShare;
}

StandingVerdict judge_two_motions(const TwoMotions& m) {
  if (!m.reestimate_valid || m.reestimate_inliers <= 0) return StandingVerdict::kUnsure;
  if (m.agree()) {
    const bool near = m.reestimate_m <= kNearRadiusM;
    const bool view_kept = m.reestimate_inliers >= kKeptShare * m.standing_inliers;
    const bool departed = m.reestimate_precise && m.departing_s >= kDepartureS;
    return near || view_kept || departed ? StandingVerdict::kMoved : StandingVerdict::kUnsure;
  }
  const double outside_share = static_cast<double>(m.outside_moved_gate) / m.reestimate_inliers;
  if (outside_share >= kConflictShare && m.reestimate_m <= kLeftRadiusM) return StandingVerdict::kHeld;
  return StandingVerdict::kUnsure;
}

bool StandingDetector::still(const SE3& reference, const SE3& T_cam_world) {
  const PoseDistance d = pose_distance(reference, T_cam_world);
  return d.translation_m <= kStillRadiusM && d.rotation_rad <= kStillAngleRad;
}

void StandingDetector::update(std::int64_t t_ns, const SE3& T_cam_world, int n_inliers) {
  if (anchor_) {  // fixed while standing: a slow drag cannot move it
    if (still(*anchor_, T_cam_world)) standing_inliers_ = std::max(standing_inliers_, n_inliers);
    return;
  }
  if (!window_start_ || !still(*window_start_, T_cam_world)) {
    window_start_ = T_cam_world;
    window_start_ns_ = t_ns;
    return;
  }
  if (static_cast<double>(t_ns - window_start_ns_) * 1e-9 >= kStandingWindowS) {
    anchor_ = T_cam_world;
    standing_inliers_ = n_inliers;
  }
}

void StandingDetector::forget() {
  anchor_.reset();
  window_start_.reset();
  departing_ = false;
}

void StandingDetector::note_departure(std::int64_t t_ns, const TwoMotions& m) {
  const bool continues = m.agree() && m.reestimate_precise;
  if (!continues || !departing_ || m.moved_m <= departure_m_) {
    departing_ = continues;
    departure_start_ns_ = t_ns;
  }
  departure_m_ = m.moved_m;
}

double StandingDetector::departing_s(std::int64_t t_ns, double moved_m) const {
  if (!departing_ || moved_m <= departure_m_) return 0.0;
  return static_cast<double>(t_ns - departure_start_ns_) * 1e-9;
}

}  // namespace sitepose::tracking
