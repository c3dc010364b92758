#include "sitepose/tracking/tracker.hpp"

#include <algorithm>
#include <iterator>
#include <map>
#include <set>
#include <unordered_set>

#include "sitepose/core/log.hpp"
#include "sitepose/core/stopwatch.hpp"
#include "sitepose/optim/reprojection_costs.hpp"
#include "sitepose/tracking/pose_refinement.hpp"

namespace sitepose::tracking {

namespace {

// ORB-SLAM2 thresholds, named (METHOD.md "Core tracker").
constexpr int kMinMatchesMotionModel = 20;  // else widen the window / relocalise
constexpr int kMinInliersMotionModel = 10;
constexpr double kMotionModelRadiusPx = 7.0;  // stereo (ORB-SLAM2 TrackWithMotionModel)
constexpr double kLocalMapRadiusPx = 1.0;     // times 2.5 / 4 by viewing angle
constexpr double kLocalMapRatio = 0.8;
constexpr int kMaxLocalKeyframes = 80;

// ORB-SLAM2's local map search: ratio test, viewing angle and scale checks,
// radius times 2.5 (head-on) or 4.
SearchParams local_map_search(double radius_px) {
  SearchParams params;
  params.radius_px = radius_px;
  params.ratio = kLocalMapRatio;
  params.check_view_angle = true;
  return params;
}

// The object share of the feature budget: enough for pass 2 to use static
// machines, small enough not to starve the background.
constexpr double kObjectBudgetFraction = 0.4;

features::StereoExtractorOptions extraction_options(const config::OrbConfig& orb, features::TaskPool* pool) {
  features::StereoExtractorOptions options;
  options.pool = pool;
  options.masked_area_features = std::max(100, static_cast<int>(orb.n_features * kObjectBudgetFraction));
  return options;
}

Status check_frame(const StereoFrame& frame, const cv::Mat& instance_labels, const StereoCamera& camera) {
  if (frame.left.empty() || frame.right.empty() || frame.left.size() != frame.right.size() ||
      frame.left.type() != CV_8UC1 || frame.right.type() != CV_8UC1) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "frame " + std::to_string(frame.seq) + ": left and right must be 8-bit gray images of equal size");
  }
  if (frame.left.cols != camera.width || frame.left.rows != camera.height) {
    return make_error(ErrorCode::kInvalidArgument,
                      "frame " + std::to_string(frame.seq) + ": image size " +
                          std::to_string(frame.left.cols) + "x" + std::to_string(frame.left.rows) +
                          " differs from the camera's " + std::to_string(camera.width) + "x" +
                          std::to_string(camera.height));
  }
  if (!instance_labels.empty() &&
      (instance_labels.type() != CV_16UC1 || instance_labels.size() != frame.left.size())) {
    return make_error(ErrorCode::kInvalidArgument, "instance labels must be CV_16UC1 of the image size");
  }
  return ok_status();
}

// Positions, levels and instance tags of the frame's keypoints.
void tag_keypoints(const cv::Mat& instance_labels, PreparedFrame& out) {
  const int n = out.features.size();
  out.uv_px.reserve(n);
  out.octave.reserve(n);
  out.instance.assign(n, 0);
  for (int i = 0; i < n; ++i) {
    const cv::KeyPoint& kp = out.features.keypoints[i];
    out.uv_px.emplace_back(kp.pt.x, kp.pt.y);
    out.octave.push_back(kp.octave);
    if (!instance_labels.empty()) {
      const int x = std::clamp(static_cast<int>(std::lround(kp.pt.x)), 0, instance_labels.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(kp.pt.y)), 0, instance_labels.rows - 1);
      out.instance[i] = instance_labels.at<std::uint16_t>(y, x);
    }
  }
}

// What site-map culling must leave (MapData::set_tracker_keyframes): the
// reference keyframe and the keyframe observing most of the frame's matches.
std::vector<map::KeyFrameId> tracker_keyframes(map::KeyFrameId reference,
                                               const std::map<map::KeyFrameId, int>& votes) {
  std::vector<map::KeyFrameId> keyframes;
  if (reference != map::kNoKeyFrame) keyframes.push_back(reference);
  const auto most = std::max_element(votes.begin(), votes.end(),
                                     [](const auto& a, const auto& b) { return a.second < b.second; });
  if (most != votes.end() && most->first != reference) keyframes.push_back(most->first);
  return keyframes;
}

}  // namespace

Tracker::Tracker(const StereoCamera& camera, const config::SiteposeConfig& config, map::SharedMap& map,
                 MapperLink mapper, features::TaskPool* pool)
    : camera_(camera),
      config_(config),
      map_(map),
      mapper_(std::move(mapper)),
      extractor_(config.orb, config.stereo, camera, extraction_options(config.orb, pool)),
      pool_(pool),
      motion_ba_(camera, config.tracking),
      pyramid_{config.orb.scale_factor, config.orb.n_levels},
      relocaliser_(camera, config.tracking, pyramid_),
      hold_(config.tracking.relocalisation_hold_frames) {}

std::optional<SE3> Tracker::last_T_world_cam() const {
  if (!has_last_) return std::nullopt;
  return last_T_cam_world_.inverse();
}

void Tracker::apply_map_correction(const SE3& correction) {
  if (has_last_) last_T_cam_world_ = last_T_cam_world_ * correction.inverse();
  for (auto& [t_ns, centre] : recent_centres_) centre = correction * centre;
}

Expected<PreparedFrame> Tracker::prepare(const StereoFrame& frame, const cv::Mat& instance_labels,
                                         const cv::Mat& extraction_mask) {
  const auto start = SteadyClock::now();
  SITEPOSE_TRY_STATUS(check_frame(frame, instance_labels, camera_));
  PreparedFrame out;
  out.seq = frame.seq;
  out.t_ns = frame.t_ns();
  // The background gets the full budget, the masked area a share of its own.
  SITEPOSE_TRY(out.features, extractor_.extract(frame, extraction_mask, corner_hints()));
  out.timings.extract_left_ms = out.features.timings.extract_left_ms;
  out.timings.extract_right_ms = out.features.timings.extract_right_ms;
  out.timings.stereo_match_ms = out.features.timings.stereo_match_ms;
  tag_keypoints(instance_labels, out);
  out.grid = map::KeypointGrid(camera_.width, camera_.height, out.uv_px, out.octave);
  out.timings.total_ms = ms_since(start);
  return out;
}

SE3 Tracker::predicted_T_cam_world() const {
  return has_velocity_ ? velocity_ * last_T_cam_world_ : last_T_cam_world_;
}

std::vector<features::CornerHint> Tracker::corner_hints() const {
  std::vector<features::CornerHint> hints;
  if (!config_.tracking.keep_tracked_corners || !has_last_ || state_ == TrackingState::kLost) return hints;
  const SE3 predicted = predicted_T_cam_world();
  map_.read([&](const map::MapData& map) {
    for (const auto& [pid, octave] : last_matches_) {
      const map::MapPoint* p = map.good_point(pid);
      if (p == nullptr) continue;
      const Eigen::Vector3d p_cam = predicted * p->p_world;
      if (p_cam.z() <= 0.0) continue;
      const Eigen::Vector2d uv = camera_.project(p_cam);
      if (!camera_.in_image(uv)) continue;
      hints.push_back({cv::Point2f(float(uv.x()), float(uv.y())), octave});
    }
  });
  return hints;
}

PointView Tracker::point_view(const map::MapData& map, const map::MapPoint& point) const {
  // The span costs two keyframe look-ups a point; only the option reads it.
  return config_.tracking.trust_established_map ? make_point_view_with_span(map, point)
                                                : make_point_view(point);
}

void Tracker::optimise_pose(const PreparedFrame& frame, const std::vector<PointView>& points,
                            const std::vector<int>& match_of_keypoint, PassResult& result) const {
  if (config_.tracking.trust_established_map) {
    optimise_pose_established_first(motion_ba_, camera_, pyramid_, frame, points, match_of_keypoint, result);
  } else {
    tracking::optimise_pose(motion_ba_, pyramid_, frame, points, match_of_keypoint, result);
  }
}

bool Tracker::track_from_prediction(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                    const SE3& predicted, const std::vector<PointView>& points,
                                    SearchParams params, std::vector<int>& match, PassResult& result) const {
  int n = search_by_projection(frame, camera_, pyramid_, predicted, points, usable, params, match, nullptr);
  if (n < kMinMatchesMotionModel) {
    std::fill(match.begin(), match.end(), -1);
    params.radius_px *= 2.0;
    n = search_by_projection(frame, camera_, pyramid_, predicted, points, usable, params, match, nullptr);
  }
  if (n < kMinMatchesMotionModel) return false;
  result.T_cam_world = predicted;
  optimise_pose(frame, points, match, result);
  return result.n_inliers >= kMinInliersMotionModel;
}

bool Tracker::track_motion_model(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                 const SE3& predicted, PassResult& result) const {
  if (last_matches_.empty()) return false;
  std::vector<PointView> points;
  map_.read([&](const map::MapData& map) {
    points.reserve(last_matches_.size());
    for (const auto& [id, octave] : last_matches_) {
      const map::MapPoint* p = map.good_point(id);
      if (p == nullptr) continue;
      PointView view = point_view(map, *p);
      view.octave_hint = octave;
      points.push_back(view);
    }
  });
  SearchParams params;
  params.radius_px = kMotionModelRadiusPx;
  std::vector<int> match(frame.size(), -1);
  return track_from_prediction(frame, usable, predicted, points, params, match, result);
}

bool Tracker::track_reference_map(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                  const SE3& predicted, PassResult& result) const {
  std::vector<int> match;
  const std::vector<map::PointId> none(frame.size(), map::kNoPoint);
  const std::vector<PointView> points = local_points(frame, none, false, match);
  SearchParams params = local_map_search(kMotionModelRadiusPx);
  return track_from_prediction(frame, usable, predicted, points, params, match, result);
}

std::vector<PointView> Tracker::local_points(const PreparedFrame& frame,
                                             const std::vector<map::PointId>& tracked, bool keep_tracked,
                                             std::vector<int>& match) const {
  // Local keyframes: those sharing the tracked points, plus their best
  // covisible ones; local points: all their points.
  std::vector<PointView> points;
  match.assign(frame.size(), -1);
  map_.read([&](const map::MapData& map) {
    std::map<map::KeyFrameId, int> votes = map.keyframes_sharing(tracked);
    if (votes.empty() && map.keyframe(reference_keyframe_) != nullptr) votes[reference_keyframe_] = 1;
    std::vector<std::pair<int, map::KeyFrameId>> ranked;
    ranked.reserve(votes.size());
    for (const auto& [kf, n] : votes) ranked.emplace_back(n, kf);
    std::sort(ranked.begin(), ranked.end(), std::greater<>());
    std::set<map::KeyFrameId> local;
    for (const auto& [n, kf] : ranked) {
      if (static_cast<int>(local.size()) >= kMaxLocalKeyframes) break;
      local.insert(kf);
    }
    for (const auto& [n, kf] : ranked) {
      if (static_cast<int>(local.size()) >= kMaxLocalKeyframes) break;
      for (auto neighbour : map.best_covisible(kf, 10)) local.insert(neighbour);
    }
    // Tens of thousands of ids per frame: a hash set, not a tree (std::set
    // was a third of the local-map stage). First occurrence wins either way.
    std::unordered_set<map::PointId> seen;
    std::size_t listed = 0;
    for (map::KeyFrameId id : local) {
      if (const map::KeyFrame* kf = map.keyframe(id); kf != nullptr) listed += kf->point_of_keypoint.size();
    }
    seen.reserve(listed);
    for (int k = 0; k < frame.size(); ++k) {
      if (tracked[k] == map::kNoPoint) continue;
      if (const map::MapPoint* p = map.good_point(tracked[k]); p != nullptr) {
        seen.insert(p->id);
        if (keep_tracked) match[k] = static_cast<int>(points.size());
        points.push_back(point_view(map, *p));
      }
    }
    for (map::KeyFrameId id : local) {
      const map::KeyFrame* kf = map.keyframe(id);
      if (kf == nullptr) continue;
      for (map::PointId pid : kf->point_of_keypoint) {
        if (pid == map::kNoPoint || !seen.insert(pid).second) continue;
        if (const map::MapPoint* p = map.good_point(pid); p != nullptr) points.push_back(point_view(map, *p));
      }
    }
  });
  return points;
}

std::vector<map::PointId> Tracker::search_local_map(const PreparedFrame& frame,
                                                    const std::vector<std::uint8_t>& usable,
                                                    const PassResult& anchor, double radius_px) const {
  std::vector<int> match;
  const std::vector<PointView> points = local_points(frame, anchor.point_of_keypoint, true, match);
  search_by_projection(frame, camera_, pyramid_, anchor.T_cam_world, points, usable,
                       local_map_search(radius_px), match, nullptr, pool_);
  std::vector<map::PointId> out(frame.size(), map::kNoPoint);
  for (int k = 0; k < frame.size(); ++k) {
    if (match[k] >= 0 && usable[k]) out[k] = points[match[k]].id;
  }
  return out;
}

std::vector<std::optional<Eigen::Vector3d>> Tracker::matched_map_points(
    const PreparedFrame& frame, const std::vector<std::uint8_t>& usable, const PassResult& anchor,
    double radius_px) const {
  const std::vector<map::PointId> point_of_keypoint = search_local_map(frame, usable, anchor, radius_px);
  std::vector<std::optional<Eigen::Vector3d>> out(frame.size());
  map_.read([&](const map::MapData& map) {
    for (int k = 0; k < frame.size(); ++k) {
      if (const map::MapPoint* p = map.good_point(point_of_keypoint[k]); p != nullptr) out[k] = p->p_world;
    }
  });
  return out;
}

void Tracker::track_local_map(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                              const PassResult* anchor, PassResult& result) const {
  const auto start = SteadyClock::now();
  std::vector<int> match;
  const std::vector<PointView> points = anchor != nullptr
                                            ? local_points(frame, anchor->point_of_keypoint, false, match)
                                            : local_points(frame, result.point_of_keypoint, true, match);
  std::vector<int> visible;
  search_by_projection(frame, camera_, pyramid_, result.T_cam_world, points, usable,
                       local_map_search(kLocalMapRadiusPx), match, &visible, pool_);
  result.visible_points.clear();
  for (int i : visible) result.visible_points.push_back(points[i].id);
  result.timings.local_map_ms += ms_since(start);  // BA time is counted in motion_ba_ms
  optimise_pose(frame, points, match, result);
}

PassResult Tracker::estimate(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                             const PassResult* anchor) const {
  const auto t0 = SteadyClock::now();
  PassResult result;
  result.point_of_keypoint.assign(frame.size(), map::kNoPoint);
  result.n_usable_keypoints = static_cast<int>(std::count(usable.begin(), usable.end(), 1));
  const bool map_empty = map_.read([](const map::MapData& map) { return map.keyframe_count() == 0; });
  if (map_empty) {
    result.needs_initialisation = true;
    result.failure = "map not initialised";
    return result;
  }
  const auto t_motion = SteadyClock::now();
  bool tracked = false;
  if (anchor != nullptr) {
    // Pass 2: pass 1's pose and pass 1's local map. Only the local-map
    // search runs, matching every keypoint afresh. Pass 1's matches are not
    // given to the optimisation (that was worse on average);
    // carry_over_matches() adds them to the committed frame.
    result.T_cam_world = anchor->T_cam_world;
    result.relocalised = anchor->relocalised;
    tracked = true;
  } else if (has_last_ && state_ != TrackingState::kLost) {
    const SE3 predicted = predicted_T_cam_world();
    tracked = track_motion_model(frame, usable, predicted, result);
    // Too few of the last frame's points re-found (e.g. a machine passing
    // close hides most of them): the reference keyframe's map from the
    // predicted pose before relocalisation, which could pick a keyframe
    // whose points lie on that machine.
    if (!tracked) tracked = track_reference_map(frame, usable, predicted, result);
  }
  bool relocalised = false;
  if (!tracked) {
    // A relocalisation counts only when its pose, after the local map, is
    // as precise as an OK pose; otherwise the next candidate, and the next
    // frame, try again (on repeated structure a weak one landed 2.7 m off).
    relocalised = relocaliser_.relocalise(map_, frame, usable, result, [&](PassResult& r) {
      track_local_map(frame, usable, anchor, r);
      return precise_pose(r, config_.tracking.min_inliers_ok) &&
             found_share(r) >= kMinRelocalisationFoundShare;
    });
    tracked = relocalised;
    if (relocalised)
      spdlog::debug(
          "tracking: relocalised at frame {}: {} inliers of {} map points in view ({:.2f}), sigma {:.4f} m",
          frame.seq, result.n_inliers, result.visible_points.size(), found_share(result),
          position_sigma_m(result));
  }
  result.timings.motion_model_ms =
      ms_since(t_motion) - result.timings.motion_ba_ms - result.timings.local_map_ms;
  if (!tracked) {
    result.failure = "motion model and relocalisation found too few matches";
    result.timings.total_ms = ms_since(t0);
    return result;
  }
  if (!relocalised) track_local_map(frame, usable, anchor, result);
  result.valid = result.n_inliers >= config_.tracking.min_inliers_recovering;
  if (!result.valid) result.failure = "only " + std::to_string(result.n_inliers) + " inliers";
  result.timings.total_ms = ms_since(t0);
  return result;
}

bool Tracker::within_reprojection_gate(const PreparedFrame& frame, int k, const Eigen::Vector3d& p_world,
                                       const SE3& T_cam_world) const {
  const Eigen::Vector3d p_cam = T_cam_world * p_world;
  const double sqrt_information = 1.0 / pyramid_.scale(frame.octave[k]);
  const double u_right_px = frame.features.u_right[k];
  if (u_right_px >= 0.0) {
    Eigen::Vector3d r;
    const Eigen::Vector3d observed_px(frame.uv_px[k].x(), frame.uv_px[k].y(), u_right_px);
    return optim::whitened_reprojection<3>(camera_, p_cam, observed_px, sqrt_information, &r, nullptr) &&
           r.squaredNorm() <= config_.tracking.chi2_stereo;
  }
  Eigen::Vector2d r;
  return optim::whitened_reprojection<2>(camera_, p_cam, frame.uv_px[k], sqrt_information, &r, nullptr) &&
         r.squaredNorm() <= config_.tracking.chi2_mono;
}

int Tracker::carry_over_matches(const PreparedFrame& frame, const PassResult& anchor,
                                PassResult& result) const {
  const auto n = static_cast<std::size_t>(frame.size());
  // estimate() sizes both to the frame, even when it fails; a PassResult made
  // otherwise (default-constructed, another frame's) has nothing to give or take.
  if (anchor.point_of_keypoint.size() != n || result.point_of_keypoint.size() != n) return 0;
  std::set<map::PointId> matched(result.point_of_keypoint.begin(), result.point_of_keypoint.end());
  int carried = 0;
  map_.read([&](const map::MapData& map) {
    for (int k = 0; k < frame.size(); ++k) {
      const map::PointId id = anchor.point_of_keypoint[k];
      if (id == map::kNoPoint || result.point_of_keypoint[k] != map::kNoPoint || matched.count(id) != 0)
        continue;
      const map::MapPoint* point = map.good_point(id);
      if (point == nullptr || !within_reprojection_gate(frame, k, point->p_world, result.T_cam_world))
        continue;
      result.point_of_keypoint[k] = id;
      matched.insert(id);
      ++carried;
    }
  });
  return carried;
}

namespace {

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
  return v;
}

bool Tracker::update_state(const PassResult& result, bool precise, bool confirmed) {
  // After a relocalisation the last pose is stale (the machine drove on
  // while tracking was lost): no velocity from it, and no OK until the new
  // pose has held for relocalisation_hold_frames frames with enough inliers.
  const bool relocalised = result.relocalised || state_ == TrackingState::kLost;
  if (relocalised) {
    ++counters_.relocalisations;
    hold_.restart();
  }
  hold_.update(precise, confirmed);
  state_ = precise && !hold_.holding() ? TrackingState::kOk : TrackingState::kRecovering;
  return relocalised;
}

std::string Tracker::state_reason(const PassResult& result) const {
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
    if (start_provisional_map_if_due(frame, usable, pose)) return pose;
    ++counters_.frames_lost;
    state_ = TrackingState::kLost;
    has_velocity_ = false;
    last_close_points_.clear();
    recent_centres_.clear();
    pose.state = TrackingState::kLost;
    pose.state_reason = verdict.dropped ? not_precise_reason(tracked) : tracked.failure;
    // Keep the last pose for relocalisation; the outputs carry LOST.
    if (has_last_) pose.T_world_cam = last_T_cam_world_.inverse();
    return pose;
  }
  frames_lost_in_a_row_ = 0;
  lost_with_view_since_ns_ = -1;
  PassResult joined;
  const PassResult& result = provisional_since_ == map::kNoKeyFrame
                                 ? tracked
                                 : settle_provisional_map(frame, usable, tracked, joined);
  if (&result == &joined) verdict = judge_hold(frame, joined);  // held as a relocalisation

  const bool relocalised = update_state(result, verdict.precise, verdict.confirmed);
  // Precise where it is, but where it is was guessed.
  if (provisional_since_ != map::kNoKeyFrame) state_ = TrackingState::kRecovering;
  // A join is a relocalisation of a tracked frame: the last pose moved with
  // the map (apply_map_correction), so the velocity is still good.
  const bool joined_now = &result == &joined;
  has_velocity_ = has_last_ && (!relocalised || joined_now);
  if (has_velocity_) velocity_ = result.T_cam_world * last_T_cam_world_.inverse();
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
  record_in_map(result);
  // A pose that has not held yet adds nothing to the map: if it is wrong,
  // its points would be wrong where the map is right.
  if (!hold_.holding() && need_keyframe(frame, result, usable)) create_keyframe(frame, result, usable);

  pose.state = state_;
  pose.state_reason = state_reason(result);
  pose.T_world_cam = result.T_cam_world.inverse();
  pose.covariance = result.covariance_world_cam.value_or(Matrix6d::Identity() * 1e6);
  pose.counters.features_used = result.n_inliers;
  pose.counters.features_used_pass1 = result.n_inliers;
  return pose;
}

// The map points' visible / found counts (culling of points), and, with
// site-map culling, the keyframes this frame uses (it must leave them; no
// other culling reads them, so the vote is skipped without it).
void Tracker::record_in_map(const PassResult& result) {
  const bool site_culling = config_.mapping.site_culling;
  map_.write([&](map::MapData& map) {
    for (map::PointId pid : result.visible_points) {
      if (map::MapPoint* p = map.point(pid); p != nullptr) ++p->n_visible;
    }
    for (map::PointId pid : result.point_of_keypoint) {
      if (map::MapPoint* p = map.point(pid); p != nullptr) ++p->n_found;
    }
    if (site_culling) {
      map.set_tracker_keyframes(
          tracker_keyframes(reference_keyframe_, map.keyframes_sharing(result.point_of_keypoint)));
    }
  });
}

void Tracker::count_close_repeatability(const PreparedFrame& frame, const PassResult& result) {
  std::vector<map::PointId> matched;
  std::vector<map::PointId> close;
  const double close_depth_m = config_.tracking.close_depth_baselines * camera_.baseline_m;
  for (int k = 0; k < frame.size(); ++k) {
    const map::PointId id = result.point_of_keypoint[k];
    if (id == map::kNoPoint) continue;
    matched.push_back(id);
    const double depth = frame.features.depth_m[k];
    if (depth > 0.0 && depth < close_depth_m) close.push_back(id);
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

Expected<PoseEstimate> Tracker::track(const StereoFrame& frame) {
  SITEPOSE_TRY(PreparedFrame prepared, prepare(frame));
  const std::vector<std::uint8_t> usable(prepared.size(), 1);
  const PassResult result = estimate(prepared, usable);
  return commit(prepared, result, usable);
}

}  // namespace sitepose::tracking
