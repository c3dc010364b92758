#include "sitepose/tracking/tracker.hpp"

#include <algorithm>
#include <map>
#include <numbers>
#include <optional>
#include <utility>

#include "sitepose/core/log.hpp"
#include "sitepose/tracking/pose_refinement.hpp"

// Tracker, continued: the map's first keyframe and the keyframe decision
// and insertion (part of commit(); estimation is in tracker.cpp).

namespace sitepose::tracking {
namespace {

// ORB-SLAM2 thresholds, named (METHOD.md "Core tracker").
constexpr int kMinNewClosePoints = 100;  // new keyframe: create at least this many
// A camera this close to its reference keyframe (translation as a share of
// the frame's median stereo depth, and rotation) sees from the same
// viewpoint: a keyframe there adds no geometry.
constexpr double kSameViewpointDepthShare = 0.01;
constexpr double kSameViewpointRad = 1.0 * std::numbers::pi / 180.0;

double median_stereo_depth_m(const PreparedFrame& frame) {
  std::vector<double> depths;
  for (int k = 0; k < frame.size(); ++k) {
    if (frame.features.has_depth(k)) depths.push_back(frame.features.depth_m[k]);
  }
  if (depths.empty()) return 0.0;
  auto middle = depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2);
  std::nth_element(depths.begin(), middle, depths.end());
  return *middle;
}

constexpr std::int64_t kStandingWindowNs = 1'000'000'000;  // stood for this long
constexpr std::int64_t kCentreHistoryNs = 2 * kStandingWindowNs;

bool same_viewpoint(const SE3& T_world_reference, const SE3& T_cam_world, double max_m) {
  const SE3 T_reference_cam = T_world_reference.inverse() * T_cam_world.inverse();
  return T_reference_cam.translation().norm() < max_m &&
         rotation_angle_rad(T_reference_cam.rotation()) < kSameViewpointRad;
}

// The camera is more than `depth_share` of the frame's median stereo depth
// from its reference keyframe (false when depth_share is 0).
bool travelled_from(const SE3& T_world_reference, const SE3& T_cam_world, const PreparedFrame& frame,
                    double depth_share) {
  if (depth_share <= 0.0) return false;
  const SE3 T_reference_cam = T_world_reference.inverse() * T_cam_world.inverse();
  return T_reference_cam.translation().norm() > depth_share * median_stereo_depth_m(frame);
}

// Close points (reliable stereo depth): tracked vs could-be-created. Only
// usable keypoints count: masked ones can never become map points.
std::pair<int, int> count_close_points(const PreparedFrame& frame, const PassResult& result,
                                       const std::vector<std::uint8_t>& usable, double close_depth_m) {
  int tracked = 0;
  int untracked = 0;
  for (int k = 0; k < frame.size(); ++k) {
    if (!usable[k] || !frame.has_close_depth(k, close_depth_m)) continue;
    if (result.point_of_keypoint[k] != map::kNoPoint) {
      ++tracked;
    } else {
      ++untracked;
    }
  }
  return {tracked, untracked};
}

// What the keyframe rules read from the map: the reference keyframe's pose
// and its points observed often enough to count.
struct KeyframeContext {
  std::optional<SE3> T_world_reference;
  int reference_matches = 0;
  int reference_background_matches = 0;  // of those, on no detected object
};

KeyframeContext read_keyframe_context(const map::MapData& map, map::KeyFrameId reference) {
  KeyframeContext context;
  const map::KeyFrame* ref = map.keyframe(reference);
  if (ref == nullptr) return context;
  context.T_world_reference = ref->T_world_cam;
  const int min_observations = map.keyframe_count() <= 2 ? 2 : 3;
  for (std::size_t k = 0; k < ref->point_of_keypoint.size(); ++k) {
    const map::PointId pid = ref->point_of_keypoint[k];
    const map::MapPoint* p = map.good_point(pid);
    if (p != nullptr && map.observation_weight(pid) >= min_observations) {
      ++context.reference_matches;
      if (ref->keypoints[k].instance == 0) ++context.reference_background_matches;
    }
  }
  return context;
}

// The pose of the keyframe nearest the camera among those that share a
// good part of the frame's inlier matches: at least kCovisibilityThreshold
// and a quarter of the most any keyframe shares, so that a keyframe seeing
// only a few far points of the view does not count (none when nothing is
// matched). Not the keyframe sharing most: once a pass has made a keyframe,
// the frames match its fresh points best, and a strip driven again would be
// mapped again keyframe by keyframe (docs/placerec/README.md).
std::optional<SE3> nearest_sharing_keyframe_pose(const map::MapData& map, const PassResult& result) {
  const std::map<map::KeyFrameId, int> votes = map.keyframes_sharing(result.point_of_keypoint);
  int most = 0;
  for (const auto& [id, n] : votes) most = std::max(most, n);
  const int min_shared = std::max(map::kCovisibilityThreshold, most / 4);
  const Eigen::Vector3d centre_world = result.T_cam_world.inverse().translation();
  std::optional<SE3> nearest;
  double nearest_m = 0.0;
  for (const auto& [id, n] : votes) {
    const map::KeyFrame* kf = map.keyframe(id);
    if (kf == nullptr || n < min_shared) continue;
    const double distance_m = (kf->camera_center() - centre_world).norm();
    if (!nearest || distance_m < nearest_m) {
      nearest = kf->T_world_cam;
      nearest_m = distance_m;
    }
  }
  return nearest;
}

}  // namespace

int Tracker::usable_stereo_points(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable) const {
  int n_stereo = 0;
  for (int k = 0; k < frame.size(); ++k) n_stereo += (usable[k] && frame.features.has_depth(k)) ? 1 : 0;
  return n_stereo;
}

bool Tracker::initialise(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable) {
  if (usable_stereo_points(frame, usable) < kMinInitialisationPoints) return false;
  // The world frame is the first keyframe's left camera.
  PassResult origin;
  origin.valid = true;
  origin.T_cam_world = SE3();
  origin.point_of_keypoint.assign(frame.size(), map::kNoPoint);
  map_travel_m_ = 0.0;
  create_keyframe(frame, origin, usable);
  last_T_cam_world_ = SE3();
  has_last_ = true;
  has_velocity_ = false;
  return true;
}

bool Tracker::need_keyframe(const PreparedFrame& frame, const PassResult& result,
                            const std::vector<std::uint8_t>& usable) const {
  // ORB-SLAM2 asks only after its local-map tracking held (30 inliers). A
  // frame that barely tracked may be anywhere (a camera moved 13 m matched
  // 17 points at its old place by chance), and its keyframe would build a
  // map where the tracker wrongly thinks it is.
  if (result.n_inliers < config_.tracking.min_inliers_ok) return false;
  // Nor from a hidden view: its new points would lie on whatever hides it.
  if (established_map_hidden(result)) return false;
  const int queued = mapper_.queue_size ? mapper_.queue_size() : 0;
  const bool mapper_idle = mapper_.is_idle ? mapper_.is_idle() : true;
  const KeyframeContext context =
      map_.read([&](const map::MapData& map) { return read_keyframe_context(map, reference_keyframe_); });
  const int reference_matches = context.reference_matches;
  const std::optional<SE3>& T_world_reference = context.T_world_reference;
  // Background (no detected object) inliers: the dynamic layer's pass 1
  // tracks on them alone, so the map must renew them even while unmasked
  // static objects keep the total high. Without objects this is the total.
  int background_inliers = 0;
  for (int k = 0; k < frame.size(); ++k) {
    if (frame.instance[k] == 0 && result.point_of_keypoint[k] != map::kNoPoint) ++background_inliers;
  }
  const auto [tracked_close, untracked_close] = count_close_points(frame, result, usable, close_depth_m());
  const bool need_close = tracked_close < config_.tracking.keyframe_min_close_points &&
                          untracked_close > config_.tracking.keyframe_new_close_points;
  const std::int64_t interval_ns =
      config_.tracking.keyframe_max_interval_frames > 0 ? 0 : static_cast<std::int64_t>(1e9);
  const bool long_since_keyframe =
      config_.tracking.keyframe_max_interval_frames > 0
          ? frame.seq - last_keyframe_seq_ >= config_.tracking.keyframe_max_interval_frames
          : frame.t_ns - last_keyframe_t_ns_ >= interval_ns;
  const double ratio = config_.tracking.keyframe_tracked_ratio;
  const bool c1 =
      long_since_keyframe || mapper_idle || result.n_inliers < 0.25 * reference_matches || need_close;
  const bool background_thinning = background_inliers < ratio * context.reference_background_matches;
  // The view changed by travel, whether or not points were lost (a tracker
  // that keeps its points would otherwise make too few keyframes): away from
  // the reference keyframe and from every keyframe sharing a good part of
  // the frame's matches. On a strip driven again the reference keyframe (the
  // last one made) lies behind while an old keyframe of the strip stands
  // beside the camera. The votes are counted only when the first test holds.
  const double travel_share = config_.tracking.keyframe_travel_depth_share;
  bool travelled =
      T_world_reference && travelled_from(*T_world_reference, result.T_cam_world, frame, travel_share);
  if (travelled) {
    const auto T_world_nearest =
        map_.read([&](const map::MapData& map) { return nearest_sharing_keyframe_pose(map, result); });
    travelled = !T_world_nearest || travelled_from(*T_world_nearest, result.T_cam_world, frame, travel_share);
  }
  const bool c2 =
      (result.n_inliers < ratio * reference_matches || background_thinning || need_close || travelled) &&
      result.n_inliers > 15;
  if (!(c1 && c2)) return false;
  // Tracked points fell while the camera stands where its reference keyframe
  // stood: something hides the view (a machine passing close). A keyframe
  // would add no geometry, only points on whatever hides it.
  // Only for a camera that stood for a second: a slowly driving one also
  // stays near its reference keyframe for a frame or two.
  if (config_.tracking.trust_established_map && T_world_reference) {
    const double max_m = kSameViewpointDepthShare * median_stereo_depth_m(frame);
    if (same_viewpoint(*T_world_reference, result.T_cam_world, max_m) &&
        stood_for_a_second(frame.t_ns, result.T_cam_world.inverse().translation(), max_m)) {
      return false;
    }
  }
  spdlog::debug(
      "tracking: keyframe wanted at frame {}: inliers {} of reference {} (background {} of {}), close "
      "tracked {} untracked {}, mapper idle {}, queued {}",
      frame.seq, result.n_inliers, reference_matches, background_inliers,
      context.reference_background_matches, tracked_close, untracked_close, mapper_idle, queued);
  if (mapper_idle) return true;
  // Stereo: insert while the mapper is busy only if its queue is short.
  if (mapper_.interrupt) mapper_.interrupt();
  return queued < 3;
}

void Tracker::remember_centre(std::int64_t t_ns, const Eigen::Vector3d& centre_world) {
  append_recent(recent_centres_, t_ns, centre_world, kCentreHistoryNs);
}

bool Tracker::stood_for_a_second(std::int64_t t_ns, const Eigen::Vector3d& centre_world, double max_m) const {
  // The newest remembered centre at least a second old.
  for (auto it = recent_centres_.rbegin(); it != recent_centres_.rend(); ++it) {
    if (it->first <= t_ns - kStandingWindowNs) return (it->second - centre_world).norm() < max_m;
  }
  return false;
}

void Tracker::create_keyframe(const PreparedFrame& frame, const PassResult& result,
                              const std::vector<std::uint8_t>& usable, bool starts_provisional_map) {
  map::KeyFrame kf;
  kf.frame_seq = frame.seq;
  kf.t_ns = frame.t_ns;
  kf.T_world_cam = result.T_cam_world.inverse();
  kf.map_travel_m = map_travel_m_;
  kf.keypoints.resize(frame.size());
  for (int k = 0; k < frame.size(); ++k) {
    map::KeyPointData& kp = kf.keypoints[k];
    kp.uv_px = frame.uv_px[k];
    kp.octave = frame.octave[k];
    kp.u_right_px = frame.features.u_right[k];
    kp.depth_m = frame.features.depth_m[k];
    kp.descriptor = map::descriptor_from_row(frame.features.descriptors, k);
    kp.instance = frame.instance[k];
  }
  kf.point_of_keypoint = result.point_of_keypoint;
  // New stereo points, nearest first: all close ones, at least 100
  // (ORB-SLAM2 Tracking::CreateNewKeyFrame).
  std::vector<std::pair<double, int>> by_depth;
  for (int k = 0; k < frame.size(); ++k) {
    if (usable[k] && frame.features.has_depth(k)) by_depth.emplace_back(frame.features.depth_m[k], k);
  }
  std::sort(by_depth.begin(), by_depth.end());
  const double close_depth = close_depth_m();
  const SE3 T_world_cam = kf.T_world_cam;
  const map::KeyFrameId id = map_.write([&](map::MapData& map) {
    const map::KeyFrameId kf_id = map.add_keyframe(std::move(kf));
    if (starts_provisional_map) map.set_provisional_since(kf_id);
    int created = 0;
    int considered = 0;
    for (const auto& [depth, k] : by_depth) {
      const map::KeyFrame* key = map.keyframe(kf_id);
      if (key->point_of_keypoint[k] == map::kNoPoint) {
        const Eigen::Vector3d p_cam = camera_.unproject(frame.uv_px[k], depth);
        map.add_point(T_world_cam * p_cam, kf_id, k);
        ++created;
      }
      ++considered;
      if (depth > close_depth && considered > kMinNewClosePoints) break;
    }
    (void)created;
    return kf_id;
  });
  reference_keyframe_ = id;
  last_keyframe_seq_ = frame.seq;
  last_keyframe_t_ns_ = frame.t_ns;
  ++counters_.keyframes_created;
  if (mapper_.enqueue) mapper_.enqueue(id);
}

}  // namespace sitepose::tracking
