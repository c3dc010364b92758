#include "sitepose/map/map_data.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_set>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/flat_id_set.hpp"
#include "sitepose/features/hamming.hpp"

namespace sitepose::map {
namespace {

// The mapped value for key, or null; const when the map is, so one body
// serves the const and the mutable accessors.
template <typename Map>
auto* find_or_null(Map& map, const typename Map::key_type& key) {
  auto it = map.find(key);
  return it == map.end() ? nullptr : &it->second;
}

}  // namespace

Descriptor descriptor_from_row(const cv::Mat& descriptors, int row) {
  SITEPOSE_CHECK(descriptors.cols == 32 && descriptors.type() == CV_8UC1);
  Descriptor d;
  std::copy_n(descriptors.ptr<std::uint8_t>(row), d.size(), d.begin());
  return d;
}

int descriptor_distance(const Descriptor& a, const Descriptor& b) {
  return features::hamming_distance(a.data(), b.data());
}

double ScalePyramid::scale(int level) const { return std::pow(scale_factor, level); }

int ScalePyramid::predict_level(double distance_m, double max_distance_m) const {
  const double ratio = max_distance_m / distance_m;
  if (!(ratio > 0.0)) return 0;
  // The epsilon keeps an exact power of the factor on its own level.
  const int level = static_cast<int>(std::ceil(std::log(ratio) / std::log(scale_factor) - 1e-9));
  return std::clamp(level, 0, n_levels - 1);
}

namespace {

std::string kf_name(KeyFrameId id) { return "keyframe " + std::to_string(id); }

// Registers every observation of `points` on its keyframe's keypoint.
Status link_observations(std::unordered_map<KeyFrameId, KeyFrame>& keyframes,
                         const std::unordered_map<PointId, MapPoint>& points) {
  for (const auto& [pid, p] : points) {
    if (p.bad) return make_error(ErrorCode::kParseError, "point " + std::to_string(pid) + " is marked bad");
    for (const auto& [kf_id, index] : p.observations) {
      auto it = keyframes.find(kf_id);
      if (it == keyframes.end()) {
        return make_error(ErrorCode::kParseError, "point " + std::to_string(pid) + " is observed by " +
                                                      kf_name(kf_id) + ", not in the map");
      }
      auto& owner = it->second.point_of_keypoint;
      if (index < 0 || index >= static_cast<int>(owner.size())) {
        return make_error(ErrorCode::kParseError, "point " + std::to_string(pid) + " names keypoint " +
                                                      std::to_string(index) + " of " + kf_name(kf_id) +
                                                      ", which has " + std::to_string(owner.size()));
      }
      if (owner[index] != kNoPoint) {
        return make_error(ErrorCode::kParseError, "keypoint " + std::to_string(index) + " of " +
                                                      kf_name(kf_id) + " is claimed by points " +
                                                      std::to_string(owner[index]) + " and " +
                                                      std::to_string(pid));
      }
      owner[index] = pid;
    }
  }
  return ok_status();
}

// Children from parents; every parent and covisible keyframe must exist.
Status link_keyframes(std::unordered_map<KeyFrameId, KeyFrame>& keyframes) {
  for (auto& [id, kf] : keyframes) {
    for (const auto& [other, weight] : kf.covisibility) {
      if (keyframes.count(other) == 0) {
        return make_error(ErrorCode::kParseError,
                          kf_name(id) + " is covisible with " + kf_name(other) + ", not in the map");
      }
    }
    for (const KeyFrameId other : kf.loop_edges) {
      const auto it = keyframes.find(other);
      if (it == keyframes.end() || other == id || it->second.loop_edges.count(id) == 0) {
        return make_error(ErrorCode::kParseError, kf_name(id) + " has a loop edge to " + kf_name(other) +
                                                      " that is not in the map or not kept on both");
      }
    }
    if (kf.parent == kNoKeyFrame) continue;
    auto parent = keyframes.find(kf.parent);
    if (parent == keyframes.end() || kf.parent == id) {
      return make_error(ErrorCode::kParseError,
                        kf_name(id) + " has parent " + kf_name(kf.parent) + ", not in the map");
    }
    parent->second.children.insert(id);
  }
  return ok_status();
}

}  // namespace

Expected<MapData> MapData::restore(ScalePyramid pyramid, std::vector<KeyFrame> keyframes,
                                   std::vector<MapPoint> points, KeyFrameId first_keyframe,
                                   KeyFrameId last_keyframe) {
  MapData map(pyramid);
  for (KeyFrame& kf : keyframes) {
    const KeyFrameId id = kf.id;
    if (id < 0 || kf.bad)
      return make_error(ErrorCode::kParseError, kf_name(id) + ": invalid id or marked bad");
    kf.point_of_keypoint.assign(kf.keypoints.size(), kNoPoint);
    kf.children.clear();
    if (!map.keyframes_.emplace(id, std::move(kf)).second) {
      return make_error(ErrorCode::kParseError, kf_name(id) + " appears twice");
    }
    map.next_keyframe_id_ = std::max(map.next_keyframe_id_, id + 1);
  }
  for (MapPoint& p : points) {
    const PointId id = p.id;
    if (id < 0) return make_error(ErrorCode::kParseError, "point id " + std::to_string(id) + " is invalid");
    if (!map.points_.emplace(id, std::move(p)).second) {
      return make_error(ErrorCode::kParseError, "point " + std::to_string(id) + " appears twice");
    }
    map.next_point_id_ = std::max(map.next_point_id_, id + 1);
  }
  SITEPOSE_TRY_STATUS(link_observations(map.keyframes_, map.points_));
  SITEPOSE_TRY_STATUS(link_keyframes(map.keyframes_));
  for (const KeyFrameId end : {first_keyframe, last_keyframe}) {
    if ((end == kNoKeyFrame) != map.keyframes_.empty() ||
        (end != kNoKeyFrame && map.keyframes_.count(end) == 0)) {
      return make_error(ErrorCode::kParseError, "first/last " + kf_name(end) + " is not in the map");
    }
  }
  map.first_keyframe_ = first_keyframe;
  map.last_keyframe_ = last_keyframe;
  return map;
}

KeyFrameId MapData::add_keyframe(KeyFrame keyframe) {
  const KeyFrameId id = next_keyframe_id_++;
  keyframe.id = id;
  keyframe.point_of_keypoint.resize(keyframe.keypoints.size(), kNoPoint);
  auto& kf = keyframes_[id] = std::move(keyframe);
  if (first_keyframe_ == kNoKeyFrame) first_keyframe_ = id;
  last_keyframe_ = id;
  for (int i = 0; i < static_cast<int>(kf.point_of_keypoint.size()); ++i) {
    const PointId pid = kf.point_of_keypoint[i];
    if (pid == kNoPoint) continue;
    MapPoint* p = point(pid);
    // A second keypoint naming the same point would leave the two sides of
    // the observation inconsistent; the first keypoint keeps it.
    if (p == nullptr || p->bad || p->observations.count(id) != 0) {
      kf.point_of_keypoint[i] = kNoPoint;
      continue;
    }
    p->observations[id] = i;
  }
  update_connections(id);
  return id;
}

PointId MapData::add_point(const Eigen::Vector3d& p_world, KeyFrameId keyframe_id, int index) {
  KeyFrame* kf = keyframe(keyframe_id);
  SITEPOSE_CHECK(kf != nullptr && index >= 0 && index < static_cast<int>(kf->keypoints.size()));
  const PointId id = next_point_id_++;
  MapPoint& p = points_[id];
  p.id = id;
  p.p_world = p_world;
  p.reference_keyframe = keyframe_id;
  p.first_keyframe = keyframe_id;
  p.observations[keyframe_id] = index;
  kf->point_of_keypoint[index] = id;
  update_point_appearance(id);
  return id;
}

void MapData::add_observation(PointId point_id, KeyFrameId keyframe_id, int index) {
  MapPoint* p = point(point_id);
  KeyFrame* kf = keyframe(keyframe_id);
  if (p == nullptr || p->bad || kf == nullptr || kf->bad) return;
  // A keyframe observes a point through at most one keypoint.
  if (auto it = p->observations.find(keyframe_id); it != p->observations.end()) {
    kf->point_of_keypoint[it->second] = kNoPoint;
  }
  const PointId previous = kf->point_of_keypoint[index];
  if (previous != kNoPoint && previous != point_id) erase_observation(previous, keyframe_id);
  p->observations[keyframe_id] = index;
  kf->point_of_keypoint[index] = point_id;
}

void MapData::erase_observation(PointId point_id, KeyFrameId keyframe_id) {
  MapPoint* p = point(point_id);
  if (p == nullptr) return;
  auto it = p->observations.find(keyframe_id);
  if (it == p->observations.end()) return;
  if (KeyFrame* kf = keyframe(keyframe_id); kf != nullptr) {
    if (kf->point_of_keypoint[it->second] == point_id) kf->point_of_keypoint[it->second] = kNoPoint;
  }
  p->observations.erase(it);
  if (p->reference_keyframe == keyframe_id && !p->observations.empty()) {
    p->reference_keyframe = p->observations.begin()->first;
  }
  // A point needs two views (a stereo creation counts as one) to stay
  // trustworthy once it has lost one; ORB-SLAM2 culls at <= 2 observations.
  if (p->observations.size() < 2) set_point_bad(point_id);
}

void MapData::set_point_bad(PointId point_id) {
  MapPoint* p = point(point_id);
  if (p == nullptr || p->bad) return;
  p->bad = true;
  for (const auto& [kf_id, index] : p->observations) {
    if (KeyFrame* kf = keyframe(kf_id); kf != nullptr && kf->point_of_keypoint[index] == point_id) {
      kf->point_of_keypoint[index] = kNoPoint;
    }
  }
  p->observations.clear();
}

void MapData::replace_point(PointId old_id, PointId new_id, AppearanceUpdate appearance) {
  if (old_id == new_id) return;
  MapPoint* old_point = point(old_id);
  MapPoint* new_point = point(new_id);
  if (old_point == nullptr || new_point == nullptr || old_point->bad || new_point->bad) return;
  const auto observations = old_point->observations;
  for (const auto& [kf_id, index] : observations) {
    KeyFrame* kf = keyframe(kf_id);
    if (kf == nullptr) continue;
    if (new_point->observations.count(kf_id) == 0) {
      kf->point_of_keypoint[index] = new_id;
      new_point->observations[kf_id] = index;
    } else {
      kf->point_of_keypoint[index] = kNoPoint;
    }
  }
  new_point->n_visible += old_point->n_visible;
  new_point->n_found += old_point->n_found;
  old_point->observations.clear();
  old_point->bad = true;
  if (appearance == AppearanceUpdate::kNow) update_point_appearance(new_id);
}

bool MapData::is_tracker_keyframe(KeyFrameId id) const {
  return std::find(tracker_keyframes_.begin(), tracker_keyframes_.end(), id) != tracker_keyframes_.end();
}

bool MapData::add_loop_edge(KeyFrameId a, KeyFrameId b) {
  KeyFrame* ka = keyframe(a);
  KeyFrame* kb = keyframe(b);
  if (ka == nullptr || kb == nullptr || ka->bad || kb->bad || a == b) return false;
  ka->loop_edges.insert(b);
  kb->loop_edges.insert(a);
  return true;
}

void MapData::set_keyframe_bad(KeyFrameId keyframe_id) {
  KeyFrame* kf = keyframe(keyframe_id);
  if (kf == nullptr || kf->bad || keyframe_id == first_keyframe_ || !kf->loop_edges.empty()) return;
  for (const auto& [other, weight] : kf->covisibility) {
    if (KeyFrame* o = keyframe(other); o != nullptr) o->covisibility.erase(keyframe_id);
  }
  for (int i = 0; i < static_cast<int>(kf->point_of_keypoint.size()); ++i) {
    const PointId pid = kf->point_of_keypoint[i];
    if (pid != kNoPoint) erase_observation(pid, keyframe_id);
  }
  // Re-parent the children: each goes to its most covisible keyframe that is
  // already connected to the tree (the parent's side), else to our parent.
  std::set<KeyFrameId> attached{kf->parent};
  std::set<KeyFrameId> pending = kf->children;
  while (!pending.empty()) {
    KeyFrameId best_child = kNoKeyFrame;
    KeyFrameId best_parent = kNoKeyFrame;
    int best_weight = -1;
    for (KeyFrameId child : pending) {
      const KeyFrame* c = keyframe(child);
      if (c == nullptr) continue;
      for (const auto& [candidate, weight] : c->covisibility) {
        if (attached.count(candidate) != 0 && weight > best_weight) {
          best_weight = weight;
          best_child = child;
          best_parent = candidate;
        }
      }
    }
    if (best_child == kNoKeyFrame) break;
    keyframe(best_child)->parent = best_parent;
    if (KeyFrame* p = keyframe(best_parent); p != nullptr) p->children.insert(best_child);
    attached.insert(best_child);
    pending.erase(best_child);
  }
  for (KeyFrameId child : pending) {
    if (KeyFrame* c = keyframe(child); c != nullptr) {
      c->parent = kf->parent;
      if (KeyFrame* p = keyframe(kf->parent); p != nullptr) p->children.insert(child);
    }
  }
  if (KeyFrame* p = keyframe(kf->parent); p != nullptr) {
    p->children.erase(keyframe_id);
    if (keep_removed_links_) removed_links_[keyframe_id] = {kf->parent, p->T_cam_world() * kf->T_world_cam};
  }
  if (last_keyframe_ == keyframe_id) last_keyframe_ = kf->parent;
  keyframes_.erase(keyframe_id);
}

std::optional<SE3> MapData::T_world_keyframe(KeyFrameId id) const {
  SE3 T_at_cam;  // the asked keyframe relative to keyframe `id` as the chain is walked
  // Each link points at a keyframe that was in the map when the link was
  // made, so a chain is at most as long as the links are many.
  for (std::size_t step = 0; step <= removed_links_.size(); ++step) {
    if (const KeyFrame* kf = keyframe(id); kf != nullptr && !kf->bad) return kf->T_world_cam * T_at_cam;
    const auto link = removed_links_.find(id);
    if (link == removed_links_.end()) return std::nullopt;
    T_at_cam = link->second.T_parent_cam * T_at_cam;
    id = link->second.parent;
  }
  return std::nullopt;
}

void MapData::update_connections(KeyFrameId keyframe_id) {
  set_connections(keyframe_id, shared_point_counts(keyframe_id));
}

MapData::SharedPointCounts MapData::shared_point_counts(KeyFrameId keyframe_id) const {
  const KeyFrame* kf = keyframe(keyframe_id);
  if (kf == nullptr) return {};
  std::vector<KeyFrameId> sharing;
  for (PointId pid : kf->point_of_keypoint) {
    const MapPoint* p = good_point(pid);
    if (p == nullptr) continue;
    for (const auto& [other, index] : p->observations) {
      if (other != keyframe_id) sharing.push_back(other);
    }
  }
  std::sort(sharing.begin(), sharing.end());
  SharedPointCounts counts;
  for (KeyFrameId other : sharing) {
    if (counts.empty() || counts.back().first != other) counts.emplace_back(other, 0);
    ++counts.back().second;
  }
  return counts;
}

void MapData::set_connections(KeyFrameId keyframe_id, const SharedPointCounts& counts) {
  KeyFrame* kf = keyframe(keyframe_id);
  if (kf == nullptr) return;
  // Drop old edges, then add those over the threshold (or the best one, so a
  // keyframe is never disconnected; ties go to the lower id).
  for (const auto& [other, weight] : kf->covisibility) {
    if (KeyFrame* o = keyframe(other); o != nullptr) o->covisibility.erase(keyframe_id);
  }
  kf->covisibility.clear();
  KeyFrameId best = kNoKeyFrame;
  int best_count = 0;
  for (const auto& [other, count] : counts) {
    KeyFrame* o = keyframe(other);
    if (o == nullptr) continue;
    if (count > best_count) {
      best_count = count;
      best = other;
    }
    if (count >= kCovisibilityThreshold) {
      kf->covisibility[other] = count;
      o->covisibility[keyframe_id] = count;
    }
  }
  if (kf->covisibility.empty() && best != kNoKeyFrame) {
    kf->covisibility[best] = best_count;
    keyframe(best)->covisibility[keyframe_id] = best_count;
  }
  // Spanning tree: a new keyframe hangs under the one it shares most with.
  if (kf->parent == kNoKeyFrame && keyframe_id != first_keyframe_ && best != kNoKeyFrame) {
    kf->parent = best;
    keyframe(best)->children.insert(keyframe_id);
  }
}

void MapData::update_point_appearance(PointId point_id) {
  const std::optional<Descriptor> descriptor = representative_descriptor(point_id);
  if (!descriptor) return;
  point(point_id)->descriptor = *descriptor;
  update_point_geometry(point_id);
}

std::optional<Descriptor> MapData::representative_descriptor(PointId point_id) const {
  const MapPoint* p = point(point_id);
  if (p == nullptr || p->bad || p->observations.empty()) return std::nullopt;
  std::vector<const KeyPointData*> views;
  for (const auto& [kf_id, index] : p->observations) {
    const KeyFrame* kf = keyframe(kf_id);
    if (kf == nullptr) continue;
    views.push_back(&kf->keypoints[index]);
  }
  if (views.empty()) return std::nullopt;
  // Each distance is computed once: the matrix is symmetric.
  const std::size_t n = views.size();
  std::vector<int> distance(n * n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      distance[i * n + j] = distance[j * n + i] =
          descriptor_distance(views[i]->descriptor, views[j]->descriptor);
    }
  }
  std::size_t best = 0;
  int best_median = 1 << 30;
  std::vector<int> others;
  others.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    others.clear();
    for (std::size_t j = 0; j < n; ++j) {
      if (i != j) others.push_back(distance[i * n + j]);
    }
    int median = 0;
    if (!others.empty()) {
      std::nth_element(others.begin(), others.begin() + static_cast<std::ptrdiff_t>(others.size() / 2),
                       others.end());
      median = others[others.size() / 2];
    }
    if (median < best_median) {
      best_median = median;
      best = i;
    }
  }
  return views[best]->descriptor;
}

void MapData::update_point_geometry(PointId point_id) {
  const MapPoint* p = point(point_id);
  if (p == nullptr) return;
  const auto geometry =
      point_geometry(point_id, p->p_world, [](const KeyFrame& kf) { return kf.camera_center(); });
  if (geometry) set_point_geometry(point_id, *geometry);
}

void MapData::set_point_geometry(PointId point_id, const PointGeometry& geometry) {
  MapPoint* p = point(point_id);
  if (p == nullptr) return;
  if (geometry.normal) p->normal = *geometry.normal;
  if (geometry.has_distances) {
    p->min_distance_m = geometry.min_distance_m;
    p->max_distance_m = geometry.max_distance_m;
  }
}

std::vector<KeyFrameId> MapData::best_covisible(KeyFrameId keyframe_id, int n) const {
  const KeyFrame* kf = keyframe(keyframe_id);
  if (kf == nullptr) return {};
  std::vector<std::pair<int, KeyFrameId>> sorted;
  for (const auto& [other, weight] : kf->covisibility) sorted.emplace_back(weight, other);
  std::sort(sorted.begin(), sorted.end(), std::greater<>());
  std::vector<KeyFrameId> result;
  for (const auto& [weight, other] : sorted) {
    if (static_cast<int>(result.size()) >= n) break;
    result.push_back(other);
  }
  return result;
}

std::map<KeyFrameId, int> MapData::keyframes_sharing(const std::vector<PointId>& points) const {
  // Every observation of every point (~15 000 a frame) into a flat counter;
  // the map is built from its few distinct keyframes.
  FlatIdCounter counts(128);
  for (PointId id : points) {
    const MapPoint* p = good_point(id);
    if (p == nullptr) continue;
    for (const auto& [kf, index] : p->observations) counts.add(kf);
  }
  std::map<KeyFrameId, int> shared;
  for (const auto& [kf, n] : counts.entries()) shared.emplace(kf, n);
  return shared;
}

KeyFrameId keyframe_sharing_most(const std::map<KeyFrameId, int>& votes) {
  const auto most = std::max_element(votes.begin(), votes.end(),
                                     [](const auto& a, const auto& b) { return a.second < b.second; });
  return most == votes.end() ? kNoKeyFrame : most->first;
}

std::optional<double> map_travel_at(const MapData& map, const std::map<KeyFrameId, int>& sharing,
                                    const std::map<KeyFrameId, int>& sharing_close,
                                    const Eigen::Vector3d& camera_centre_m) {
  std::optional<double> least_m;
  const auto consider = [&](KeyFrameId id) {
    const KeyFrame* kf = map.keyframe(id);
    if (kf == nullptr) return;
    const double travel_m = map_travel_via(kf->map_travel_m, kf->camera_center(), camera_centre_m);
    if (!least_m || travel_m < *least_m) least_m = travel_m;
  };
  consider(keyframe_sharing_most(sharing));
  for (const auto& [id, count] : sharing_close) {
    if (count >= kCovisibilityThreshold) consider(id);
  }
  return least_m;
}

int MapData::observation_weight(PointId point_id) const {
  const MapPoint* p = good_point(point_id);
  if (p == nullptr) return 0;
  int weight = 0;
  for (const auto& [kf_id, index] : p->observations) {
    const KeyFrame* kf = keyframe(kf_id);
    if (kf == nullptr) continue;
    weight += kf->keypoints[index].u_right_px >= 0.0 ? 2 : 1;
  }
  return weight;
}

const KeyFrame* MapData::keyframe(KeyFrameId id) const { return find_or_null(keyframes_, id); }
KeyFrame* MapData::keyframe(KeyFrameId id) { return find_or_null(keyframes_, id); }
const MapPoint* MapData::point(PointId id) const { return find_or_null(points_, id); }
MapPoint* MapData::point(PointId id) { return find_or_null(points_, id); }
const MapPoint* MapData::good_point(PointId id) const {
  const MapPoint* p = point(id);
  return (p == nullptr || p->bad) ? nullptr : p;
}

std::size_t MapData::purge_bad_points() {
  return std::erase_if(points_, [](const auto& entry) { return entry.second.bad; });
}

void MapData::move_keyframes_from(KeyFrameId first, const SE3& correction) {
  for (auto& [id, kf] : keyframes_) {
    if (id >= first) kf.T_world_cam = correction * kf.T_world_cam;
  }
  const Eigen::Matrix3d R = correction.rotation_matrix();
  for (auto& [id, p] : points_) {
    if (p.first_keyframe < first) continue;
    p.p_world = correction * p.p_world;
    p.normal = R * p.normal;
  }
}

void MapData::set_map_travel_from(KeyFrameId first, const Eigen::Vector3d& place_m,
                                  double travel_at_place_m) {
  for (auto& [id, kf] : keyframes_) {
    if (id >= first) kf.map_travel_m = map_travel_via(travel_at_place_m, place_m, kf.camera_center());
  }
}

void MapData::set_map_travel_along_spanning_tree() {
  std::unordered_map<KeyFrameId, double> travel_m;
  for (const auto& [id, unused] : keyframes_) {
    // Up from `id` to a root, a cycle's closing keyframe or a keyframe whose
    // travel is known; then down again, adding each edge.
    std::vector<KeyFrameId> chain;
    std::unordered_set<KeyFrameId> on_chain;
    for (KeyFrameId at = id; travel_m.count(at) == 0 && on_chain.insert(at).second;) {
      chain.push_back(at);
      const KeyFrameId parent = keyframes_.at(at).parent;
      if (parent == kNoKeyFrame || keyframes_.count(parent) == 0) break;
      at = parent;
    }
    for (auto at = chain.rbegin(); at != chain.rend(); ++at) {
      const KeyFrame& kf = keyframes_.at(*at);
      const auto parent = travel_m.find(kf.parent);
      travel_m[*at] =
          parent == travel_m.end()
              ? 0.0
              : parent->second + (kf.camera_center() - keyframes_.at(kf.parent).camera_center()).norm();
    }
  }
  for (auto& [id, kf] : keyframes_) kf.map_travel_m = travel_m.at(id);
}

std::vector<KeyFrameId> MapData::drop_keyframes_from(KeyFrameId first) {
  std::vector<KeyFrameId> dropped;
  for (const auto& [id, kf] : keyframes_) {
    if (id >= first && id != first_keyframe_) dropped.push_back(id);
  }
  std::sort(dropped.begin(), dropped.end(), std::greater<>());
  for (const KeyFrameId id : dropped) {
    // A loop edge protects a keyframe from culling, not from this.
    for (const KeyFrameId other : keyframes_.at(id).loop_edges) {
      if (KeyFrame* o = keyframe(other); o != nullptr) o->loop_edges.erase(id);
    }
    keyframes_.at(id).loop_edges.clear();
    set_keyframe_bad(id);
  }
  // A frame tracked in the dropped keyframes has no place in the map.
  std::erase_if(removed_links_, [&](const auto& entry) { return entry.first >= first; });
  last_keyframe_ = kNoKeyFrame;
  for (const auto& [id, kf] : keyframes_) last_keyframe_ = std::max(last_keyframe_, id);
  provisional_since_ = kNoKeyFrame;
  joined_unconfirmed_since_ = kNoKeyFrame;
  return dropped;
}

}  // namespace sitepose::map
