#include "sitepose/tracking/tracker.hpp"

#include <algorithm>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/tracking/pose_refinement.hpp"

// Tracker, continued: commit() — the tracking state and its reasons, the
// relocalisation hold, the motion model's memory and the map statistics a
// committed frame leaves (estimation is in tracker.cpp, the keyframe
// decision and insertion in keyframe_insertion.cpp, provisional maps in
// provisional_map.cpp).

namespace sitepose::tracking {

namespace {

// What site-map culling must leave (MapData::set_tracker_keyframes): the
// reference keyframe and the keyframe observing most of the frame's matches.
std::vector<map::KeyFrameId> tracker_keyframes(map::KeyFrameId reference,
                                               const std::map<map::KeyFrameId, int>& votes) {
  std::vector<map::KeyFrameId> keyframes;
  if (reference != map::kNoKeyFrame) keyframes.push_back(reference);
  const map::KeyFrameId most = map::keyframe_sharing_most(votes);
  if (most != map::kNoKeyFrame && most != reference) keyframes.push_back(most);
  return keyframes;
}

std::string not_precise_reason(const PassResult& result) {
  return "relocalised pose not precise: " + std::to_string(result.n_inliers) + " inliers, position sigma " +
         std::to_string(position_sigma_m(result)) + " m";
}

}  // namespace

Tracker::HoldVerdict Tracker::judge_hold(const PreparedFrame& frame, const PassResult& result) const {
  // A relocalisation must start precise and stay so while it is held (see
  // RelocalisationHold::fails()); else it is dropped and the next frame
  // relocalises anew. While held, a frame counts towards OK only when its
  // pose is precise also with the map points' own errors (distant points
  // seen before from elsewhere can hold a pose 0.1 m off at a small sigma).
  HoldVerdict v;
  const bool starts_hold = result.relocalised || state_ == TrackingState::kLost;
  const bool held = starts_hold || hold_.holding();
  // A pose on what is left of a hidden established map is kept for
  // tracking, but not called OK (established_map_hidden()).
  v.precise = result.valid && precise_pose(result, config_.tracking.min_inliers_ok) &&
              !established_map_hidden(result);
  double map_sigma_m = 0.0;
  if (held && v.precise) {
    map_sigma_m = map_.read([&](const map::MapData& data) {
      return map_aware_position_sigma_m(camera_, pyramid_, frame, data, result);
    });
  }
  v.confirmed = v.precise && map_sigma_m <= kMaxHeldMapAwareSigmaM;
  v.dropped = result.valid && ((starts_hold && !v.precise) || (!starts_hold && hold_.fails(v.precise)));
  v.close_inliers = close_inliers(frame, result, close_depth_m());
  return v;
}

double Tracker::close_depth_m() const { return config_.tracking.close_depth_baselines * camera_.baseline_m; }

bool Tracker::update_state(const PassResult& result, const HoldVerdict& verdict) {
  // After a relocalisation the last pose is stale (the machine drove on
  // while tracking was lost): no velocity from it, and no OK until the new
  // pose has been confirmed in relocalisation_hold_frames frames in a row.
  const bool relocalised = result.relocalised || state_ == TrackingState::kLost;
  if (relocalised) {
    ++counters_.relocalisations;
    hold_.restart();
  }
  hold_.update(verdict.precise, verdict.confirmed);
  // The hold after a join has ended: the joined keyframes' place holds.
  if (joined_unconfirmed_since_ != map::kNoKeyFrame && !hold_.holding()) {
    joined_unconfirmed_since_ = map::kNoKeyFrame;
    map_.write([](map::MapData& map) { map.set_joined_unconfirmed_since(map::kNoKeyFrame); });
  }
  const bool ok = verdict.precise && !hold_.holding() && verdict.close_inliers >= kMinOkCloseInliers;
  state_ = ok ? TrackingState::kOk : TrackingState::kRecovering;
  return relocalised;
}

std::string Tracker::state_reason(const PassResult& result, const HoldVerdict& verdict) const {
  if (state_ != TrackingState::kRecovering) return "";
  if (provisional_since_ != map::kNoKeyFrame) {
    return "provisional map since keyframe " + std::to_string(provisional_since_) +
           ": not joined to the site map";
  }
  if (!hold_.holding()) {
    if (result.n_inliers < config_.tracking.min_inliers_ok)
      return "only " + std::to_string(result.n_inliers) + " inliers";
    if (established_map_hidden(result))
      return "the established map is hidden: " + std::to_string(result.established_matched) + " of its " +
             std::to_string(result.established_in_view) + " points in view matched";
    if (verdict.close_inliers < kMinOkCloseInliers)
      return "only " + std::to_string(verdict.close_inliers) + " inliers with a stereo depth under " +
             std::to_string(close_depth_m()) + " m";
    return "position sigma " + std::to_string(position_sigma_m(result)) + " m";
  }
  return "relocalised, held " + std::to_string(hold_.held_frames()) + " of " +
         std::to_string(hold_.hold_frames()) + " frames";
}

void Tracker::commit_initialisation(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                    PoseEstimate& pose) {
  if (initialise(frame, usable)) {
    state_ = TrackingState::kOk;
    pose.state = TrackingState::kOk;
    pose.T_world_cam = SE3();
    pose.covariance = Matrix6d::Zero();  // the origin is exact by definition
    pose.map_travel_m = 0.0;
    pose.reference_keyframe = reference_keyframe_;  // made at the origin: T_reference_cam = I
    last_matches_.clear();
    map_.read([&](const map::MapData& map) {
      const map::KeyFrame* kf = map.keyframe(reference_keyframe_);
      for (int k = 0; k < static_cast<int>(kf->point_of_keypoint.size()); ++k) {
        if (kf->point_of_keypoint[k] != map::kNoPoint) {
          last_matches_.emplace_back(kf->point_of_keypoint[k], kf->keypoints[k].octave);
        }
      }
    });
    pose.counters.features_used = static_cast<int>(last_matches_.size());
  } else {
    state_ = TrackingState::kLost;
    pose.state = TrackingState::kLost;
    pose.state_reason = "too few stereo points to initialise the map";
    ++counters_.frames_lost;
  }
}

PoseEstimate Tracker::commit(const PreparedFrame& frame, const PassResult& tracked,
                             const std::vector<std::uint8_t>& usable) {
  ++counters_.frames;
  PoseEstimate pose;
  pose.t_ns = frame.t_ns;
  pose.seq = frame.seq;
  pose.counters.features_extracted = frame.size();

  if (tracked.needs_initialisation) {
    commit_initialisation(frame, usable, pose);
    return pose;
  }

  HoldVerdict verdict = judge_hold(frame, tracked);
  if (!tracked.valid || verdict.dropped) {
    if (verdict.dropped) hold_.stop();
    if (joined_unconfirmed_since_ != map::kNoKeyFrame) drop_unconfirmed_join();
    if (start_provisional_map_if_due(frame, usable, pose)) return pose;
    ++counters_.frames_lost;
    state_ = TrackingState::kLost;
    has_velocity_ = false;
    last_close_points_.clear();
    recent_centres_.clear();
    recent_steps_.clear();
    pose.state = TrackingState::kLost;
    pose.state_reason = verdict.dropped ? not_precise_reason(tracked) : tracked.failure;
    // Keep the last pose for relocalisation; the outputs carry LOST.
    if (has_last_) pose.T_world_cam = last_T_cam_world_.inverse();
    pose.map_travel_m = map_travel_m_;
    return pose;
  }
  frames_lost_in_a_row_ = 0;
  lost_with_view_since_ns_ = -1;
  PassResult joined;
  const PassResult& result = provisional_since_ == map::kNoKeyFrame
                                 ? tracked
                                 : settle_provisional_map(frame, usable, tracked, joined);
  if (&result == &joined) verdict = judge_hold(frame, joined);  // held as a relocalisation

  const bool relocalised = update_state(result, verdict);
  // Precise where it is, but where it is was guessed.
  if (provisional_since_ != map::kNoKeyFrame) state_ = TrackingState::kRecovering;
  // A join is a relocalisation of a tracked frame: the last pose moved with
  // the map (apply_map_correction), so the velocity is still good.
  const bool joined_now = &result == &joined;
  has_velocity_ = has_last_ && (!relocalised || joined_now);
  // The next frame is tracked against this keyframe (estimate()); the one
  // from before the loss may be far away.
  if (relocalised && !joined_now) refer_to_most_shared_keyframe(result);
  if (has_velocity_) velocity_ = result.T_cam_world * last_T_cam_world_.inverse();
  remember_step(frame.t_ns, has_velocity_ ? std::optional<SE3>(velocity_) : std::nullopt);
  last_T_cam_world_ = result.T_cam_world;
  remember_centre(frame.t_ns, result.T_cam_world.inverse().translation());
  has_last_ = true;
  last_matches_.clear();
  for (int k = 0; k < frame.size(); ++k) {
    if (result.point_of_keypoint[k] != map::kNoPoint) {
      last_matches_.emplace_back(result.point_of_keypoint[k], frame.octave[k]);
    }
  }
  count_close_repeatability(frame, result);
  record_in_map(result, pose);
  create_keyframe_if_needed(frame, result, usable, pose);

  pose.state = state_;
  pose.state_reason = state_reason(result, verdict);
  pose.T_world_cam = result.T_cam_world.inverse();
  pose.covariance = result.covariance_world_cam.value_or(Matrix6d::Identity() * kGuessedPlaceVariance);
  // Precise within a provisional map, which was put where dead reckoning
  // guessed (26 m off on lostmap): the covariance must not claim the place.
  if (provisional_since_ != map::kNoKeyFrame) pose.covariance += Matrix6d::Identity() * kGuessedPlaceVariance;
  pose.map_travel_m = map_travel_m_;
  pose.counters.features_used = result.n_inliers;
  pose.counters.features_used_pass1 = result.n_inliers;
  return pose;
}

void Tracker::create_keyframe_if_needed(const PreparedFrame& frame, const PassResult& result,
                                        const std::vector<std::uint8_t>& usable, PoseEstimate& pose) {
  // A pose that has not held yet adds nothing to the map: if it is wrong,
  // its points would be wrong where the map is right.
  if (hold_.holding() || !need_keyframe(frame, result, usable)) return;
  create_keyframe(frame, result, usable);
  // The frame is that keyframe now: the map's later corrections of the
  // keyframe are the frame's.
  pose.reference_keyframe = reference_keyframe_;
  pose.T_reference_cam = SE3();
}

// The map points' visible / found counts (culling of points), how far the
// map was built out to this frame (map_travel_m_, from its close matches,
// which count_close_repeatability() left in last_close_points_), with
// site-map culling the keyframes this frame uses (it must leave them), and
// in `pose` where the frame stands relative to its reference keyframe and
// how many of its matches old keyframes observe.
void Tracker::record_in_map(const PassResult& result, PoseEstimate& pose) {
  const bool site_culling = config_.mapping.site_culling;
  const Eigen::Vector3d centre_world = result.T_cam_world.inverse().translation();
  map_.write([&](map::MapData& map) {
    for (map::PointId pid : result.visible_points) {
      if (map::MapPoint* p = map.point(pid); p != nullptr) ++p->n_visible;
    }
    const std::int64_t old_before_ns = pose.t_ns - static_cast<std::int64_t>(kOldKeyFrameAge_s * 1e9);
    for (map::PointId pid : result.point_of_keypoint) {
      map::MapPoint* p = map.point(pid);
      if (p == nullptr) continue;
      ++p->n_found;
      ++pose.counters.matches;
      // Keyframe ids grow with time, so the first observation is the oldest.
      if (p->observations.empty()) continue;
      if (const map::KeyFrame* oldest = map.keyframe(p->observations.begin()->first);
          oldest != nullptr && oldest->t_ns <= old_before_ns) {
        ++pose.counters.matches_from_old_keyframes;
      }
    }
    counters_.matches += pose.counters.matches;
    counters_.matches_from_old_keyframes += pose.counters.matches_from_old_keyframes;
    const std::map<map::KeyFrameId, int> sharing = map.keyframes_sharing(result.point_of_keypoint);
    const std::map<map::KeyFrameId, int> sharing_close = map.keyframes_sharing(last_close_points_);
    if (const std::optional<double> travel_m =
            map::map_travel_at(map, sharing, sharing_close, centre_world)) {
      map_travel_m_ = *travel_m;
    }
    if (site_culling) map.set_tracker_keyframes(tracker_keyframes(reference_keyframe_, sharing));
    if (const map::KeyFrame* reference = map.keyframe(reference_keyframe_); reference != nullptr) {
      pose.reference_keyframe = reference_keyframe_;
      pose.T_reference_cam = reference->T_cam_world() * result.T_cam_world.inverse();
    }
  });
}

void Tracker::count_close_repeatability(const PreparedFrame& frame, const PassResult& result) {
  std::vector<map::PointId> matched;
  std::vector<map::PointId> close;
  const double close_depth = close_depth_m();
  for (int k = 0; k < frame.size(); ++k) {
    const map::PointId id = result.point_of_keypoint[k];
    if (id == map::kNoPoint) continue;
    matched.push_back(id);
    if (frame.has_close_depth(k, close_depth)) close.push_back(id);
  }
  std::sort(matched.begin(), matched.end());
  std::sort(close.begin(), close.end());
  if (!last_close_points_.empty()) {
    std::vector<map::PointId> again;
    std::set_intersection(last_close_points_.begin(), last_close_points_.end(), matched.begin(),
                          matched.end(), std::back_inserter(again));
    counters_.close_points_previous += static_cast<long>(last_close_points_.size());
    counters_.close_points_rematched += static_cast<long>(again.size());
  }
  last_close_points_ = std::move(close);
}

}  // namespace sitepose::tracking
