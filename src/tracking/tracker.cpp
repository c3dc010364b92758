#include "sitepose/tracking/tracker.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "sitepose/core/flat_id_set.hpp"
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
// Local points are viewed in up to this many runs on the pool, of at least
// kMinPointViewsPerRun points each (fewer points: one run on the caller).
constexpr int kPointViewRuns = 4;
constexpr int kMinPointViewsPerRun = 64;

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

Status check_images(const StereoFrame& frame, const StereoCamera& camera) {
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
  return ok_status();
}

Status check_instance_labels(const cv::Mat& instance_labels, const cv::Size& image_size) {
  if (!instance_labels.empty() &&
      (instance_labels.type() != CV_16UC1 || instance_labels.size() != image_size)) {
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
  return prepare(frame, [&]() -> Expected<FrameMasks> {
    return FrameMasks{instance_labels, extraction_mask};
  });
}

Expected<PreparedFrame> Tracker::prepare(const StereoFrame& frame, const MaskMaker& make_masks) {
  const auto start = SteadyClock::now();
  SITEPOSE_TRY_STATUS(check_images(frame, camera_));
  PreparedFrame out;
  out.seq = frame.seq;
  out.t_ns = frame.t_ns();
  cv::Mat instance_labels;
  const auto make_extraction_mask = [&]() -> Expected<cv::Mat> {
    SITEPOSE_TRY(FrameMasks masks, make_masks());
    SITEPOSE_TRY_STATUS(check_instance_labels(masks.instance_labels, frame.left.size()));
    instance_labels = masks.instance_labels;
    return masks.extraction_mask;
  };
  // The background gets the full budget, the masked area a share of its own.
  SITEPOSE_TRY(out.features,
               extractor_.extract(frame.left, frame.right, make_extraction_mask, corner_hints()));
  out.timings.extract_left_ms = out.features.timings.extract_left_ms;
  out.timings.extract_right_ms = out.features.timings.extract_right_ms;
  out.timings.stereo_match_ms = out.features.timings.stereo_match_ms;
  out.timings.mask_overrun_ms = out.features.timings.mask_overrun_ms;
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
  std::vector<map::PointId> local_ids;  // the local keyframes' other points, first seen first
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
    // Tens of thousands of ids per frame, a few thousand distinct: a flat
    // hash set (core/flat_id_set.hpp). First occurrence wins.
    FlatIdSet seen(4096);
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
        if (pid != map::kNoPoint && seen.insert(pid)) local_ids.push_back(pid);
      }
    }
  });
  append_point_views(local_ids, points);
  return points;
}

void Tracker::append_point_views(const std::vector<map::PointId>& ids, std::vector<PointView>& points) const {
  // A few thousand points a frame, ~0.2 us each in cache misses: in runs on
  // the pool, each run under its own read lock (SharedMap's lock is a leaf:
  // no thread waits on the pool while holding it). A point culled between
  // the caller's lock and a run's is left out, as if culled a moment earlier.
  const int n_ids = static_cast<int>(ids.size());
  const int n_runs = pool_ != nullptr ? std::clamp(n_ids / kMinPointViewsPerRun, 1, kPointViewRuns) : 1;
  std::vector<std::vector<PointView>> runs(static_cast<std::size_t>(n_runs));
  const auto view_run = [&](int r) {
    const int begin = static_cast<int>(static_cast<std::int64_t>(n_ids) * r / n_runs);
    const int end = static_cast<int>(static_cast<std::int64_t>(n_ids) * (r + 1) / n_runs);
    std::vector<PointView>& out = runs[static_cast<std::size_t>(r)];
    out.reserve(static_cast<std::size_t>(end - begin));
    map_.read([&](const map::MapData& map) {
      for (int i = begin; i < end; ++i) {
        if (const map::MapPoint* p = map.good_point(ids[i]); p != nullptr) out.push_back(point_view(map, *p));
      }
    });
  };
  if (n_runs > 1) {
    pool_->run(n_runs, view_run);
  } else {
    view_run(0);
  }
  for (const std::vector<PointView>& run : runs) points.insert(points.end(), run.begin(), run.end());
}

AnchorLocalMap Tracker::local_map_of(const PreparedFrame& frame, const PassResult& anchor) const {
  AnchorLocalMap local;
  local.points = local_points(frame, anchor.point_of_keypoint, true, local.match_of_anchor);
  return local;
}

std::vector<map::PointId> Tracker::search_local_map(const PreparedFrame& frame,
                                                    const std::vector<std::uint8_t>& usable,
                                                    const PassResult& anchor, double radius_px,
                                                    const AnchorLocalMap* anchor_local) const {
  std::optional<AnchorLocalMap> listed_here;
  if (anchor_local == nullptr) anchor_local = &listed_here.emplace(local_map_of(frame, anchor));
  const std::vector<PointView>& points = anchor_local->points;
  std::vector<int> match = anchor_local->match_of_anchor;
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
    double radius_px, const AnchorLocalMap* anchor_local) const {
  const std::vector<map::PointId> point_of_keypoint =
      search_local_map(frame, usable, anchor, radius_px, anchor_local);
  std::vector<std::optional<Eigen::Vector3d>> out(frame.size());
  map_.read([&](const map::MapData& map) {
    for (int k = 0; k < frame.size(); ++k) {
      if (const map::MapPoint* p = map.good_point(point_of_keypoint[k]); p != nullptr) out[k] = p->p_world;
    }
  });
  return out;
}

void Tracker::track_local_map(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                              const PassResult* anchor, const AnchorLocalMap* anchor_local,
                              PassResult& result) const {
  const auto start = SteadyClock::now();
  std::vector<int> match;
  std::vector<PointView> listed_here;
  const std::vector<PointView>* points = &listed_here;
  if (anchor == nullptr) {
    listed_here = local_points(frame, result.point_of_keypoint, true, match);
  } else if (anchor_local != nullptr) {
    points = &anchor_local->points;
    match.assign(frame.size(), -1);  // every keypoint matched afresh
  } else {
    listed_here = local_points(frame, anchor->point_of_keypoint, false, match);
  }
  std::vector<int> visible;
  search_by_projection(frame, camera_, pyramid_, result.T_cam_world, *points, usable,
                       local_map_search(kLocalMapRadiusPx), match, &visible, pool_);
  result.visible_points.clear();
  for (int i : visible) result.visible_points.push_back((*points)[i].id);
  result.timings.local_map_ms += ms_since(start);  // BA time is counted in motion_ba_ms
  optimise_pose(frame, *points, match, result);
  if (anchor == nullptr) {
    // optimise_pose keeps point_of_keypoint[k] == points[match[k]].id for
    // the inliers.
    auto local = std::make_shared<AnchorLocalMap>();
    local->match_of_anchor.assign(match.size(), -1);
    for (std::size_t k = 0; k < match.size(); ++k) {
      if (result.point_of_keypoint[k] != map::kNoPoint) local->match_of_anchor[k] = match[k];
    }
    local->points = std::move(listed_here);
    result.local_map = std::move(local);
  }
}

std::string Tracker::distant_found_text(const PassResult& result) const {
  const std::optional<double> share =
      map_.read([&](const map::MapData& map) { return far_found_share(map, result); });
  return share ? fmt::format("{:.2f}", *share) : std::string("none in view");
}

bool Tracker::holds_as_relocalisation(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                      PassResult& candidate) const {
  track_local_map(frame, usable, nullptr, nullptr, candidate);
  return precise_pose(candidate, config_.tracking.min_inliers_ok) &&
         found_share(candidate) >= kMinRelocalisationFoundShare &&
         map_.read([&](const map::MapData& map) { return finds_distant_background(map, candidate); });
}

PassResult Tracker::estimate(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                             const PassResult* anchor, const AnchorLocalMap* anchor_local) const {
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
  } else if (has_last_ && state_ != TrackingState::kLost && !has_velocity_) {
    // Motion unknown (the frame after a relocalisation or the first map): a
    // search around the last pose looks for a moving camera's points where
    // they were, and at 0.5 m a frame it matched the wrong ones, which the
    // hold then confirmed (docs/tracking/provisional_map.md, "The frame
    // after a relocalisation"). Descriptors need no prediction; without
    // enough of them, relocalisation.
    tracked = relocaliser_.track_against_keyframe(map_, frame, usable, reference_keyframe_, result);
    spdlog::debug("tracking: frame {} against keyframe {} by descriptors: {} ({} inliers)", frame.seq,
                  reference_keyframe_, tracked ? "tracked" : "failed", result.n_inliers);
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
      return holds_as_relocalisation(frame, usable, r);
    });
    tracked = relocalised;
    if (relocalised && spdlog::default_logger_raw()->should_log(spdlog::level::debug))
      spdlog::debug(
          "tracking: relocalised at frame {}: {} inliers of {} map points in view ({:.2f}; distant {}), "
          "sigma {:.4f} m",
          frame.seq, result.n_inliers, result.visible_points.size(), found_share(result),
          distant_found_text(result), position_sigma_m(result));
  }
  result.timings.motion_model_ms =
      ms_since(t_motion) - result.timings.motion_ba_ms - result.timings.local_map_ms;
  if (!tracked) {
    result.failure = "motion model and relocalisation found too few matches";
    result.timings.total_ms = ms_since(t0);
    return result;
  }
  if (!relocalised) track_local_map(frame, usable, anchor, anchor_local, result);
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

Expected<PoseEstimate> Tracker::track(const StereoFrame& frame) {
  SITEPOSE_TRY(PreparedFrame prepared, prepare(frame));
  const std::vector<std::uint8_t> usable(prepared.size(), 1);
  const PassResult result = estimate(prepared, usable);
  return commit(prepared, result, usable);
}

}  // namespace sitepose::tracking
