#pragma once
// The map of keyframes and points, and the bookkeeping that keeps them
// consistent: observations both ways, covisibility weights, spanning tree,
// representative descriptors, normals and scale ranges.
//
// Thread-safety: MapData is NOT thread-safe. It is owned by SharedMap
// (shared_map.hpp), which is the only way the tracker and the local mapper
// reach it.

#include <functional>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/map/map_types.hpp"

namespace sitepose::map {

// Scale pyramid of the extractor: level l has scale factor^l. Map points
// derive their scale-invariance range from it (ORB-SLAM2).
struct ScalePyramid {
  double scale_factor = 1.2;
  int n_levels = 8;
  double scale(int level) const;
  // Predicted pyramid level of a point seen from distance_m, given its range.
  int predict_level(double distance_m, double max_distance_m) const;
};

// Minimum shared points for a covisibility edge (ORB-SLAM2 uses 15).
inline constexpr int kCovisibilityThreshold = 15;

// A point's mean viewing direction and scale-invariance distance range.
struct PointGeometry {
  std::optional<Eigen::Vector3d> normal;  // none when the views cancel out (the old one stays)
  bool has_distances = false;             // false without a reference view (the old ones stay)
  double min_distance_m = 0.0;
  double max_distance_m = 0.0;
};

class MapData {
 public:
  explicit MapData(ScalePyramid pyramid = {}) : pyramid_(pyramid) {}

  const ScalePyramid& pyramid() const { return pyramid_; }

  // Rebuilds a saved map (map files): keyframes and points keep their ids,
  // poses, covisibility, parents and point appearance as given; each
  // keyframe's point_of_keypoint and children are derived from the points'
  // observations and the parents, so the two sides cannot disagree. New ids
  // continue after the largest. Names the first inconsistency (an
  // observation of a missing keyframe or keypoint, a keypoint claimed by two
  // points, a parent, covisible or loop-edge keyframe that is not in the
  // map, a loop edge kept on one side only).
  static Expected<MapData> restore(ScalePyramid pyramid, std::vector<KeyFrame> keyframes,
                                   std::vector<MapPoint> points, KeyFrameId first_keyframe,
                                   KeyFrameId last_keyframe);

  // Inserts a keyframe (its id is assigned and returned); its
  // point_of_keypoint entries must name existing points and are registered as
  // observations. Updates covisibility and the spanning-tree parent.
  // Entries naming a missing or bad point, or a point an earlier keypoint of
  // the same keyframe already names, are cleared (a keyframe observes a point
  // through one keypoint).
  KeyFrameId add_keyframe(KeyFrame keyframe);
  // Creates a point observed by keypoint `index` of `keyframe`; returns its id.
  PointId add_point(const Eigen::Vector3d& p_world, KeyFrameId keyframe, int index);

  void add_observation(PointId point, KeyFrameId keyframe, int index);
  // Removes one observation; a point left with < 2 observations becomes bad.
  void erase_observation(PointId point, KeyFrameId keyframe);
  void set_point_bad(PointId point);
  // Removes a keyframe: its observations are erased and its children are
  // re-parented to the covisible keyframe they share most with. The first
  // keyframe is never removed (it anchors the gauge), nor one with a loop
  // edge (it holds the loop).
  void set_keyframe_bad(KeyFrameId keyframe);
  // Joins two keyframes by a loop edge (both ways); false when either is
  // missing or bad, or they are the same.
  bool add_loop_edge(KeyFrameId a, KeyFrameId b);
  // Replaces `old_point` by `new_point` in every keyframe that observed it.
  // kDeferred: the caller refreshes new_point's appearance (descriptor,
  // normal, depth range) later with update_point_appearance, e.g. under a
  // second, shorter write lock.
  enum class AppearanceUpdate { kNow, kDeferred };
  void replace_point(PointId old_point, PointId new_point,
                     AppearanceUpdate appearance = AppearanceUpdate::kNow);

  // Recomputes the covisibility edges of a keyframe from its points:
  // set_connections(keyframe, shared_point_counts(keyframe)). The two halves
  // let a caller count under a read lock and set under a short write lock.
  void update_connections(KeyFrameId keyframe);
  // Per other keyframe (by id), how many of this keyframe's good points it
  // also observes.
  using SharedPointCounts = std::vector<std::pair<KeyFrameId, int>>;
  SharedPointCounts shared_point_counts(KeyFrameId keyframe) const;
  void set_connections(KeyFrameId keyframe, const SharedPointCounts& counts);
  // Representative descriptor, mean normal and distance range of a point:
  // the descriptor of representative_descriptor, then update_point_geometry.
  void update_point_appearance(PointId point);
  // The view's descriptor with the least median distance to the others (the
  // first of equals); nullopt for a missing or bad point or one without views.
  std::optional<Descriptor> representative_descriptor(PointId point) const;
  // Mean normal and distance range only (ORB-SLAM2 UpdateNormalAndDepth):
  // what changes when a point or a keyframe moves but its views do not.
  // = set_point_geometry(point, point_geometry(point, its p_world, the
  // keyframes' camera centres)).
  void update_point_geometry(PointId point);
  // The geometry `point` would have at p_world with each observing keyframe's
  // camera centre given by centre_of(const KeyFrame&): e.g. after a
  // correction planned under the read lock and not yet applied. nullopt
  // for a missing or bad point or one without views.
  template <typename CentreOf>
  std::optional<PointGeometry> point_geometry(PointId point, const Eigen::Vector3d& p_world,
                                              CentreOf&& centre_of) const;
  void set_point_geometry(PointId point, const PointGeometry& geometry);

  // Keyframes sharing most points with `keyframe`, best first (up to n).
  std::vector<KeyFrameId> best_covisible(KeyFrameId keyframe, int n) const;
  // Per keyframe, how many of `points` it observes (kNoPoint, missing and
  // bad points skipped): the keyframes a frame's matches share.
  std::map<KeyFrameId, int> keyframes_sharing(const std::vector<PointId>& points) const;

  // ORB-SLAM2 MapPoint::Observations(): a stereo observation (keypoint with
  // u_right_px >= 0) counts 2, a monocular one 1. The culling thresholds of
  // the mapper and the tracker's keyframe decision are stated in this count.
  // 0 for a missing or bad point.
  int observation_weight(PointId point) const;

  const KeyFrame* keyframe(KeyFrameId id) const;
  KeyFrame* keyframe(KeyFrameId id);
  const MapPoint* point(PointId id) const;
  MapPoint* point(PointId id);
  // A point that exists and is not bad.
  const MapPoint* good_point(PointId id) const;

  std::size_t keyframe_count() const { return keyframes_.size(); }
  std::size_t point_count() const { return points_.size(); }
  KeyFrameId first_keyframe() const { return first_keyframe_; }
  KeyFrameId last_keyframe() const { return last_keyframe_; }
  const std::unordered_map<KeyFrameId, KeyFrame>& keyframes() const { return keyframes_; }
  const std::unordered_map<PointId, MapPoint>& points() const { return points_; }

  // The keyframes the tracker works from (its reference keyframe and the
  // one sharing most of its last frame's matches), set by the tracker with
  // each committed frame; site-map culling leaves them (site_culling.hpp).
  // Not part of a saved map.
  void set_tracker_keyframes(std::vector<KeyFrameId> keyframes) { tracker_keyframes_ = std::move(keyframes); }
  const std::vector<KeyFrameId>& tracker_keyframes() const { return tracker_keyframes_; }
  bool is_tracker_keyframe(KeyFrameId id) const;

  // Bad points are kept until no tracker snapshot can refer to them; the
  // mapper calls this once per keyframe to reclaim the memory.
  std::size_t purge_bad_points();

  // A provisional map (docs/tracking/provisional_map.md): the keyframes with ids
  // >= provisional_since(), started by the tracker after it lost the site
  // map, placed by dead reckoning and not yet joined to the site map. Their
  // points are those they created. kNoKeyFrame: none. Not part of a saved
  // map (encode_map leaves the provisional keyframes out).
  KeyFrameId provisional_since() const { return provisional_since_; }
  void set_provisional_since(KeyFrameId first) { provisional_since_ = first; }
  // A provisional map joined to the site map whose join no relocalisation
  // hold has confirmed yet (docs/tracking/provisional_map.md): the keyframes
  // with ids >= joined_unconfirmed_since() and the points they created stand
  // where the join put them. kNoKeyFrame: none. Not saved either.
  KeyFrameId joined_unconfirmed_since() const { return joined_unconfirmed_since_; }
  void set_joined_unconfirmed_since(KeyFrameId first) { joined_unconfirmed_since_ = first; }
  // Moves the keyframes with ids >= first and the points they created
  // rigidly: T_world_cam' = correction * T_world_cam, p' = correction * p
  // (normals turn with it; distance ranges stay). The join of a
  // provisional map to the site map.
  void move_keyframes_from(KeyFrameId first, const SE3& correction);
  // After that join at `place_m`, where the site map had been built out
  // over `travel_at_place_m`: each keyframe with id >= first gets that
  // distance plus its straight distance from the place (map_travel_m).
  void set_map_travel_from(KeyFrameId first, const Eigen::Vector3d& place_m, double travel_at_place_m);
  // Sets every keyframe's map_travel_m to its path length along the
  // spanning tree from the tree's root (0 there): for a map file saved
  // without them. The parents are the keyframes each shared most with when
  // it was made, so this comes close to what the tracker kept. A parent
  // cycle (a corrupt file) is cut where it closes.
  void set_map_travel_along_spanning_tree();
  // Removes the keyframes with ids >= first (set_keyframe_bad, newest
  // first; their points lose those observations) and clears the
  // provisional and joined-unconfirmed marks; last_keyframe() becomes the
  // newest one left. The first keyframe is never removed. Returns the ids
  // removed.
  std::vector<KeyFrameId> drop_keyframes_from(KeyFrameId first);

  // Where removed keyframes hung: kept on, set_keyframe_bad records each
  // removed keyframe's parent and its pose relative to that parent, so a
  // frame tracked from it can still be re-expressed in the final map
  // (ORB-SLAM2 keeps a culled keyframe's parent and Tcp). Off by default: a
  // map that runs for days would collect one entry per keyframe ever
  // culled. Keyframes dropped with a provisional map leave no entry. Not
  // part of a saved map.
  void keep_removed_keyframe_links(bool keep) { keep_removed_links_ = keep; }
  // T_world_cam of keyframe `id`: its own when it is in the map, else its
  // parent's composed with the pose relative to it, up to a keyframe in
  // the map. nullopt: never known, or removed without a recorded link.
  std::optional<SE3> T_world_keyframe(KeyFrameId id) const;

 private:
  ScalePyramid pyramid_;
  std::unordered_map<KeyFrameId, KeyFrame> keyframes_;
  std::unordered_map<PointId, MapPoint> points_;
  KeyFrameId next_keyframe_id_ = 0;
  PointId next_point_id_ = 0;
  KeyFrameId first_keyframe_ = kNoKeyFrame;
  KeyFrameId last_keyframe_ = kNoKeyFrame;
  struct RemovedKeyFrameLink {
    KeyFrameId parent = kNoKeyFrame;
    SE3 T_parent_cam;
  };
  bool keep_removed_links_ = false;
  std::unordered_map<KeyFrameId, RemovedKeyFrameLink> removed_links_;
  std::vector<KeyFrameId> tracker_keyframes_;
  KeyFrameId provisional_since_ = kNoKeyFrame;
  KeyFrameId joined_unconfirmed_since_ = kNoKeyFrame;
};

// The keyframe with most of keyframes_sharing()'s votes (the smallest id of
// equals); kNoKeyFrame without votes.
KeyFrameId keyframe_sharing_most(const std::map<KeyFrameId, int>& votes);

// The map travel of a place reached from `from_m`, where the map had been
// built out over `travel_at_from_m`: that plus the straight distance (the
// one rule of the tracker, a provisional map's join and a closed loop).
inline double map_travel_via(double travel_at_from_m, const Eigen::Vector3d& from_m,
                             const Eigen::Vector3d& place_m) {
  return travel_at_from_m + (place_m - from_m).norm();
}

// How far the map had been built out to a camera at `camera_centre_m`: the
// least of map_travel_m plus the straight distance from the keyframe, over
// the keyframe sharing most of the camera's matches (`sharing`,
// keyframes_sharing() of all of them) and every keyframe that shares at
// least kCovisibilityThreshold of its close matches (`sharing_close`: the
// points that fix its position). A camera that re-finds the close points
// of a place mapped earlier (a strip driven again, a standing machine) is
// tied to the map as it was built there and gets that place's distance
// back; one that extends the map adds what it drives. Far points alone,
// which every keyframe of a site may share, do not count. nullopt when no
// keyframe shares a match.
std::optional<double> map_travel_at(const MapData& map, const std::map<KeyFrameId, int>& sharing,
                                    const std::map<KeyFrameId, int>& sharing_close,
                                    const Eigen::Vector3d& camera_centre_m);

template <typename CentreOf>
std::optional<PointGeometry> MapData::point_geometry(PointId point_id, const Eigen::Vector3d& p_world,
                                                     CentreOf&& centre_of) const {
  const MapPoint* p = point(point_id);
  if (p == nullptr || p->bad || p->observations.empty()) return std::nullopt;
  PointGeometry geometry;
  Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
  for (const auto& [kf_id, index] : p->observations) {
    if (const KeyFrame* kf = keyframe(kf_id); kf != nullptr)
      normal_sum += (p_world - centre_of(*kf)).normalized();
  }
  if (normal_sum.squaredNorm() > 0.0) geometry.normal = normal_sum.normalized();
  // Scale invariance range from the reference keyframe's view.
  const KeyFrame* ref = keyframe(p->reference_keyframe);
  if (ref == nullptr || p->observations.count(ref->id) == 0) ref = keyframe(p->observations.begin()->first);
  if (ref == nullptr) return geometry;
  const int level = ref->keypoints[p->observations.at(ref->id)].octave;
  const double distance = (p_world - centre_of(*ref)).norm();
  geometry.has_distances = true;
  geometry.max_distance_m = distance * pyramid_.scale(level);
  geometry.min_distance_m = geometry.max_distance_m / pyramid_.scale(pyramid_.n_levels - 1);
  return geometry;
}

}  // namespace sitepose::map
