#include <algorithm>
#include <numbers>
#include <optional>
#include <string>

#include "sitepose/core/log.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/tracking/tracker.hpp"

// Tracker, continued: provisional maps (docs/tracking/provisional_map.md).
// When the site map stays lost while the camera sees enough to build a map,
// the tracker starts a new one where dead reckoning puts the camera, in the
// site frame, and keeps tracking RECOVERING in it: the pose is precise
// relative to its surroundings but its place is a guess. Each frame then
// also tries to relocalise among the site map's keyframes; when that holds,
// the provisional map is moved rigidly onto the site map (the two poses of
// that frame give the move) and tracking goes on in the site map. A
// provisional map that tracking leaves before it is joined is dropped: its
// place was never confirmed, and a later relocalisation into it would be
// called OK at the wrong place.

namespace sitepose::tracking {
namespace {

// A join is made when this many frames in a row found it, agreeing within
// the bounds below (loop closing asks 3 consistent keyframes, ORB-SLAM2).
// One frame can find a wrong place on a repeated pattern, which the next
// frames do not confirm; the right place is found in every frame once in
// view (measurements: docs/tracking/provisional_map.md).
constexpr int kJoinConfirmFrames = 5;
constexpr double kJoinAgreementM = 0.2;
constexpr double kJoinAgreementRad = 2.0 * std::numbers::pi / 180.0;

// Dead reckoning carries the mean step of this long before the loss.
constexpr std::int64_t kDeadReckoningWindowNs = 1'000'000'000;

bool agree(const SE3& a, const SE3& b) {
  const SE3 d = a.inverse() * b;
  return d.translation().norm() <= kJoinAgreementM && rotation_angle_rad(d.rotation()) <= kJoinAgreementRad;
}

}  // namespace

void Tracker::remember_step(std::int64_t t_ns, const std::optional<SE3>& step) {
  if (!step) {
    recent_steps_.clear();
    return;
  }
  append_recent(recent_steps_, t_ns, *step, kDeadReckoningWindowNs);
}

SE3 Tracker::mean_recent_step() const {
  if (recent_steps_.empty()) return SE3();
  Vector6d sum = Vector6d::Zero();
  for (const auto& [t_ns, step] : recent_steps_) sum += step.log();
  return SE3::exp(sum / static_cast<double>(recent_steps_.size()));
}

SE3 Tracker::dead_reckoned_T_cam_world() const {
  SE3 T_cam_world = last_T_cam_world_;
  for (int i = 0; i < frames_lost_in_a_row_; ++i) T_cam_world = velocity_at_loss_ * T_cam_world;
  return T_cam_world;
}

void Tracker::with_mapper_held(const std::function<void(map::MapData&)>& change) {
  // The mapper reads keyframe poses, computes, then writes (new points,
  // local BA): a move between the two would be undone or mixed. Held, it
  // finishes its keyframe (a local BA is interrupted) and waits.
  if (mapper_.pause) mapper_.pause();
  map_.write(change);
  if (mapper_.resume) mapper_.resume();
}

std::size_t Tracker::drop_keyframes_from(map::KeyFrameId first) {
  std::vector<map::KeyFrameId> dropped;
  with_mapper_held([&](map::MapData& map) { dropped = map.drop_keyframes_from(first); });
  if (mapper_.removed) {
    for (const map::KeyFrameId id : dropped) mapper_.removed(id);
  }
  return dropped.size();
}

void Tracker::drop_provisional_map(const char* why) {
  const map::KeyFrameId first = provisional_since_;
  const std::size_t dropped = drop_keyframes_from(first);
  provisional_since_ = map::kNoKeyFrame;
  ++counters_.provisional_maps_dropped;
  spdlog::warn("tracking: provisional map from keyframe {} dropped ({} keyframes): {}", first, dropped, why);
}

void Tracker::drop_unconfirmed_join() {
  const map::KeyFrameId first = joined_unconfirmed_since_;
  const std::size_t dropped = drop_keyframes_from(first);
  joined_unconfirmed_since_ = map::kNoKeyFrame;
  ++counters_.joins_dropped_unconfirmed;
  spdlog::warn(
      "tracking: joined provisional map from keyframe {} dropped ({} keyframes): lost before its join was "
      "confirmed",
      first, dropped);
}

bool Tracker::start_provisional_map_if_due(const PreparedFrame& frame,
                                           const std::vector<std::uint8_t>& usable, PoseEstimate& pose) {
  if (state_ != TrackingState::kLost) {
    // The first lost frame: the motion of the last second carries on.
    velocity_at_loss_ = mean_recent_step();
    frames_lost_in_a_row_ = 0;
    lost_with_view_since_ns_ = -1;
  }
  ++frames_lost_in_a_row_;
  const double after_s = config_.tracking.new_map_after_lost_s;
  if (!(after_s > 0.0) || !has_last_) return false;
  if (usable_stereo_points(frame, usable) < kMinInitialisationPoints) return false;  // blind: no map to build
  if (lost_with_view_since_ns_ < 0) lost_with_view_since_ns_ = frame.t_ns;
  if (static_cast<double>(frame.t_ns - lost_with_view_since_ns_) < after_s * 1e9) return false;

  if (provisional_since_ != map::kNoKeyFrame) drop_provisional_map("lost in it as well");
  const SE3 T_cam_world = dead_reckoned_T_cam_world();
  PassResult origin;
  origin.valid = true;
  origin.T_cam_world = T_cam_world;
  origin.point_of_keypoint.assign(frame.size(), map::kNoPoint);
  create_keyframe(frame, origin, usable, /*starts_provisional_map=*/true);
  provisional_since_ = reference_keyframe_;
  ++counters_.provisional_maps_started;
  spdlog::warn(
      "tracking: lost for {:.1f} s with a view: provisional map from keyframe {} at the dead-reckoned "
      "pose ({} frames on the mean step before the loss)",
      static_cast<double>(frame.t_ns - lost_with_view_since_ns_) * 1e-9, provisional_since_,
      frames_lost_in_a_row_);

  last_T_cam_world_ = T_cam_world;
  velocity_ = velocity_at_loss_;
  has_velocity_ = true;
  last_matches_.clear();
  last_close_points_.clear();
  recent_centres_.clear();
  hold_.stop();
  state_ = TrackingState::kRecovering;
  frames_lost_in_a_row_ = 0;
  lost_with_view_since_ns_ = -1;
  pose.state = TrackingState::kRecovering;
  pose.state_reason = "provisional map started at the dead-reckoned pose: not joined to the site map";
  pose.T_world_cam = T_cam_world.inverse();
  pose.reference_keyframe = provisional_since_;  // the frame is that keyframe
  pose.covariance = Matrix6d::Identity() * kGuessedPlaceVariance;
  pose.map_travel_m = map_travel_m_;
  return true;
}

void Tracker::refer_to_most_shared_keyframe(const PassResult& result) {
  const map::KeyFrameId most = map_.read([&](const map::MapData& map) {
    return map::keyframe_sharing_most(map.keyframes_sharing(result.point_of_keypoint));
  });
  if (most != map::kNoKeyFrame) reference_keyframe_ = most;
}

bool Tracker::matched_in_site_map(const PassResult& result) const {
  int site = 0;
  int provisional = 0;
  map_.read([&](const map::MapData& map) {
    for (const map::PointId id : result.point_of_keypoint) {
      const map::MapPoint* p = map.good_point(id);
      if (p == nullptr) continue;
      (p->first_keyframe < provisional_since_ ? site : provisional) += 1;
    }
  });
  return site > provisional;
}

const PassResult& Tracker::settle_provisional_map(const PreparedFrame& frame,
                                                  const std::vector<std::uint8_t>& usable,
                                                  const PassResult& result, PassResult& joined) {
  if (result.relocalised && matched_in_site_map(result)) {
    // commit() refers to the relocalisation's keyframe, as after any.
    drop_provisional_map("relocalised in the site map while lost in it");
    return result;
  }
  joined = PassResult{};
  joined.point_of_keypoint.assign(frame.size(), map::kNoPoint);
  joined.n_usable_keypoints = result.n_usable_keypoints;
  const bool found = relocaliser_.relocalise(
      map_, frame, usable, joined, [&](PassResult& r) { return holds_as_relocalisation(frame, usable, r); },
      provisional_since_);
  if (!found) {
    join_correction_.reset();
    join_agreements_ = 0;
    return result;
  }
  // p_site = correction * p_provisional, from the two poses of this frame.
  const SE3 correction = joined.T_cam_world.inverse() * result.T_cam_world;
  join_agreements_ = join_correction_ && agree(*join_correction_, correction) ? join_agreements_ + 1 : 1;
  join_correction_ = correction;
  if (spdlog::default_logger_raw()->should_log(spdlog::level::debug))  // the distant share reads the map
    spdlog::debug(
        "tracking: join found at frame {} ({} in a row): {} inliers, {} site-map points in view "
        "({:.2f} found; distant {}), sigma {:.4f} m, move {:.3f} m",
        frame.seq, join_agreements_, joined.n_inliers, joined.visible_points.size(), found_share(joined),
        distant_found_text(joined), position_sigma_m(joined), correction.translation().norm());
  if (join_agreements_ < kJoinConfirmFrames) return result;
  join_correction_.reset();
  join_agreements_ = 0;
  joined.valid = true;
  const map::KeyFrameId first = provisional_since_;
  with_mapper_held([&](map::MapData& map) {
    map.move_keyframes_from(first, correction);
    map.set_provisional_since(map::kNoKeyFrame);
    map.set_joined_unconfirmed_since(first);
    // Joined where this frame found the site map: the provisional
    // keyframes' drift starts from that place's (their chain began at a
    // guess).
    const Eigen::Vector3d place_world = joined.T_cam_world.inverse().translation();
    const std::optional<double> travel_m =
        map::map_travel_at(map, map.keyframes_sharing(joined.point_of_keypoint), {}, place_world);
    if (travel_m) map.set_map_travel_from(first, place_world, *travel_m);
  });
  apply_map_correction(correction);
  provisional_since_ = map::kNoKeyFrame;
  joined_unconfirmed_since_ = first;
  refer_to_most_shared_keyframe(joined);
  ++counters_.provisional_maps_joined;
  const double move_m = correction.translation().norm();
  const double rotation_deg = rotation_angle_rad(correction.rotation()) * 180.0 / std::numbers::pi;
  counters_.largest_join_move_m = std::max(counters_.largest_join_move_m, move_m);
  counters_.largest_join_rotation_deg = std::max(counters_.largest_join_rotation_deg, rotation_deg);
  spdlog::warn(
      "tracking: provisional map from keyframe {} joined to the site map: moved {:.3f} m, {:.2f} deg", first,
      move_m, rotation_deg);
  return joined;
}

}  // namespace sitepose::tracking
