#include "sitepose/loop/loop_correction.hpp"

#include <algorithm>
#include <optional>
#include <set>
#include <unordered_set>

namespace sitepose::loop {
namespace {

struct PairHash {
  std::size_t operator()(const KeyFramePair& p) const {
    return std::hash<map::KeyFrameId>()(p.first) * 1000003U ^ std::hash<map::KeyFrameId>()(p.second);
  }
};

KeyFramePair ordered(map::KeyFrameId a, map::KeyFrameId b) {
  return a < b ? KeyFramePair{a, b} : KeyFramePair{b, a};
}

// Fuses one proposal keeping the loop side's point; true when the map
// changed. The kept point's appearance is refreshed by connect_group.
bool fuse_loop_point(map::MapData& map, const mapping::FuseProposal& f, GroupApplied& out) {
  const map::MapPoint* loop_point = map.good_point(f.point);
  const map::KeyFrame* kf = map.keyframe(f.keyframe);
  if (loop_point == nullptr || kf == nullptr || kf->bad || loop_point->observations.count(f.keyframe) != 0) {
    return false;
  }
  const map::PointId existing = kf->point_of_keypoint[static_cast<std::size_t>(f.index)];
  if (map.good_point(existing) != nullptr) {
    map.replace_point(existing, f.point, map::MapData::AppearanceUpdate::kDeferred);
    ++out.points_fused;
  } else {
    map.add_observation(f.point, f.keyframe, f.index);
    ++out.observations_added;
  }
  out.points_with_new_views.insert(f.point);
  return true;
}

// The node's nearest ancestor in the graph (itself when it is a node).
int node_of(const map::MapData& map, map::KeyFrameId id,
            const std::unordered_map<map::KeyFrameId, int>& node) {
  for (int hops = 0; id != map::kNoKeyFrame && hops < 1000; ++hops) {
    if (const auto it = node.find(id); it != node.end()) return it->second;
    const map::KeyFrame* kf = map.keyframe(id);
    if (kf == nullptr) return -1;
    id = kf->parent;
  }
  return -1;
}

// Keyframes inserted by the tracker since the copy sit in the group's old
// frame: moved by C with the points created with them.
void move_new_keyframes(map::MapData& map, const GroupCopy& group, const GroupCorrection& plan,
                        GroupApplied& out) {
  std::vector<map::KeyFrameId> inserted;
  for (const auto& [id, kf] : map.keyframes()) {
    if (!kf.bad && group.T_world_cam_all.count(id) == 0) inserted.push_back(id);
  }
  for (map::KeyFrameId id : inserted) {
    map::KeyFrame* k = map.keyframe(id);
    k->T_world_cam = plan.correction * k->T_world_cam;
    ++out.keyframes_moved;
    for (map::PointId pid : k->point_of_keypoint) {
      map::MapPoint* p = map.point(pid);
      if (p == nullptr || p->bad || p->first_keyframe != id || plan.p_world.count(pid) != 0) continue;
      if (!out.corrected_by.emplace(pid, id).second) continue;
      p->p_world = plan.correction * p->p_world;
      ++out.points_moved;
    }
  }
}

}  // namespace

GroupCopy copy_group(const map::MapData& map, map::KeyFrameId current) {
  GroupCopy copy;
  for (const auto& [id, kf] : map.keyframes()) copy.T_world_cam_all[id] = kf.T_world_cam;
  const map::KeyFrame* kf = map.keyframe(current);
  if (kf == nullptr) return copy;
  std::vector<map::KeyFrameId> ids{current};
  for (const auto& [other, weight] : kf->covisibility) ids.push_back(other);
  std::unordered_set<map::PointId> seen;
  for (map::KeyFrameId id : ids) {
    const map::KeyFrame* k = map.keyframe(id);
    if (k == nullptr || k->bad) continue;
    copy.keyframes.push_back(mapping::snapshot_keyframe(*k));
    std::vector<map::KeyFrameId>& covisible = copy.covisible_before[id];
    for (const auto& [other, weight] : k->covisibility) covisible.push_back(other);
    for (map::PointId pid : k->point_of_keypoint) {
      const map::MapPoint* p = map.good_point(pid);
      if (p != nullptr && seen.insert(pid).second) copy.points.push_back(mapping::snapshot_point(*p));
    }
  }
  return copy;
}

GroupCorrection plan_group_correction(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                      const GroupCopy& group, const VerifiedLoop& loop,
                                      const std::vector<mapping::PointSnapshot>& loop_points) {
  GroupCorrection plan;
  plan.loop = loop.candidate;
  if (group.keyframes.empty()) return plan;
  const mapping::KeyFrameSnapshot& current = group.keyframes.front();
  plan.current = current.id;
  // T_world' = C * T_world for the whole group, C = T_world_cur' * T_cur_world.
  const SE3 C = loop.T_world_cam * current.T_cam_world;
  plan.correction = C;
  std::vector<mapping::KeyFrameSnapshot> moved;
  std::unordered_map<map::KeyFrameId, SE3> correction_of;
  for (const mapping::KeyFrameSnapshot& k : group.keyframes) {
    mapping::KeyFrameSnapshot m = k;
    m.T_world_cam = C * k.T_world_cam;
    m.T_cam_world = m.T_world_cam.inverse();
    plan.T_world_cam[k.id] = m.T_world_cam;
    moved.push_back(std::move(m));
  }
  std::unordered_set<map::PointId> loop_ids;
  for (const mapping::PointSnapshot& p : loop_points) loop_ids.insert(p.id);
  for (const mapping::PointSnapshot& p : group.points) {
    if (loop_ids.count(p.id) != 0) continue;  // already on the loop side
    // The first group keyframe observing it (the group is in covisibility order).
    for (const mapping::KeyFrameSnapshot& k : group.keyframes) {
      if (!p.is_observed_by(k.id)) continue;
      plan.p_world[p.id] = C * p.p_world;
      plan.corrected_by[p.id] = k.id;
      break;
    }
  }
  // The verified matches of the current keyframe, then the search in the group.
  for (const LoopMatch& m : loop.matches) plan.fusions.push_back({m.loop_point, current.id, m.keypoint, 0});
  mapping::FuseParams params;  // ORB-SLAM2 SearchAndFuse: th = 4 there, fuse.hpp's radius here
  params.radius_scale = 4.0;
  for (const mapping::KeyFrameSnapshot& k : moved) {
    const auto found = mapping::fuse_into_keyframe(camera, pyramid, k, mapping::make_keypoint_grid(camera, k),
                                                   loop_points, params);
    plan.fusions.insert(plan.fusions.end(), found.begin(), found.end());
  }
  return plan;
}

GroupApplied apply_group_correction(map::MapData& map, const GroupCopy& group, const GroupCorrection& plan) {
  GroupApplied out;
  for (const auto& [id, T] : plan.T_world_cam) {
    if (map::KeyFrame* kf = map.keyframe(id); kf != nullptr && !kf->bad) {
      kf->T_world_cam = T;
      ++out.keyframes_moved;
    }
  }
  move_new_keyframes(map, group, plan, out);
  for (const auto& [pid, p] : plan.p_world) {
    if (map::MapPoint* point = map.point(pid); point != nullptr && !point->bad) {
      point->p_world = p;
      map.update_point_geometry(pid);  // moved with its views: descriptor unchanged
      ++out.points_moved;
    }
  }
  for (const mapping::FuseProposal& f : plan.fusions) fuse_loop_point(map, f, out);
  return out;
}

void tie_map_travel_to_loop(map::MapData& map, const GroupCorrection& plan, map::KeyFrameId loop_keyframe) {
  const map::KeyFrame* loop = map.keyframe(loop_keyframe);
  if (loop == nullptr || loop->bad) return;
  const double loop_travel_m = loop->map_travel_m;
  const Eigen::Vector3d loop_centre_m = loop->camera_center();
  for (const auto& [id, unused] : plan.T_world_cam) {
    map::KeyFrame* kf = map.keyframe(id);
    if (kf == nullptr || kf->bad) continue;
    kf->map_travel_m =
        std::min(kf->map_travel_m, map::map_travel_via(loop_travel_m, loop_centre_m, kf->camera_center()));
  }
}

GroupConnections count_group_connections(const map::MapData& map, const GroupCorrection& plan,
                                         const GroupApplied& applied) {
  GroupConnections counted;
  counted.last_keyframe = map.last_keyframe();
  for (map::PointId pid : applied.points_with_new_views) {
    if (auto descriptor = map.representative_descriptor(pid))
      counted.descriptors.emplace_back(pid, *descriptor);
  }
  for (const auto& [id, T] : plan.T_world_cam)
    counted.shared_points.emplace_back(id, map.shared_point_counts(id));
  return counted;
}

void connect_group(map::MapData& map, const GroupCopy& group, const GroupCorrection& plan,
                   const GroupConnections& counted, GroupApplied& out) {
  // Only a keyframe the tracker inserted since the count changes what was
  // counted (the mapper is paused): then count again here.
  std::optional<GroupConnections> recounted;
  if (map.last_keyframe() != counted.last_keyframe) recounted = count_group_connections(map, plan, out);
  const GroupConnections& connections = recounted ? *recounted : counted;
  for (const auto& [pid, descriptor] : connections.descriptors) {
    if (map::MapPoint* p = map.point(pid); p != nullptr && !p->bad) {
      p->descriptor = descriptor;
      map.update_point_geometry(pid);
    }
  }
  for (const auto& [id, counts] : connections.shared_points) map.set_connections(id, counts);
  std::set<map::KeyFrameId> in_group;
  for (const auto& [id, T] : plan.T_world_cam) in_group.insert(id);
  for (map::KeyFrameId id : in_group) {
    const map::KeyFrame* kf = map.keyframe(id);
    if (kf == nullptr) continue;
    const auto before_it = group.covisible_before.find(id);
    for (const auto& [other, weight] : kf->covisibility) {
      if (in_group.count(other) != 0) continue;
      if (before_it != group.covisible_before.end() &&
          std::find(before_it->second.begin(), before_it->second.end(), other) != before_it->second.end()) {
        continue;
      }
      out.loop_connections.emplace_back(id, other);
    }
  }
}

EssentialGraph build_essential_graph(const map::MapData& map,
                                     const std::unordered_map<map::KeyFrameId, SE3>& measured_before,
                                     const std::vector<KeyFramePair>& loop_edges,
                                     const std::vector<KeyFramePair>& new_edges, int min_weight) {
  EssentialGraph g;
  std::unordered_map<map::KeyFrameId, int> node;
  std::vector<map::KeyFrameId> ids;
  for (const auto& [id, kf] : map.keyframes()) {
    if (!kf.bad) ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  for (map::KeyFrameId id : ids) {
    node[id] = static_cast<int>(g.ids.size());
    g.ids.push_back(id);
    g.T_world_cam_built.push_back(map.keyframe(id)->T_world_cam);
    g.input.T_world_node.push_back(map.keyframe(id)->T_world_cam);
    g.input.fixed.push_back(id == map.first_keyframe());
  }
  std::unordered_set<KeyFramePair, PairHash> added;
  const auto add_edge = [&](map::KeyFrameId a, map::KeyFrameId b, bool measure_now) {
    const auto ia = node.find(a);
    const auto ib = node.find(b);
    if (ia == node.end() || ib == node.end() || a == b || !added.insert(ordered(a, b)).second) return false;
    const auto ba = measured_before.find(a);
    const auto bb = measured_before.find(b);
    const bool before = !measure_now && ba != measured_before.end() && bb != measured_before.end();
    const SE3 T_a = before ? ba->second : g.input.T_world_node[static_cast<std::size_t>(ia->second)];
    const SE3 T_b = before ? bb->second : g.input.T_world_node[static_cast<std::size_t>(ib->second)];
    g.input.edges.push_back({ia->second, ib->second, T_a.inverse() * T_b, 1.0});
    return true;
  };
  for (const KeyFramePair& e : new_edges) {
    if (add_edge(e.first, e.second, true)) ++g.loop_edges;
  }
  for (const KeyFramePair& e : loop_edges) {
    if (add_edge(e.first, e.second, false)) ++g.loop_edges;
  }
  for (map::KeyFrameId id : ids) {
    if (add_edge(map.keyframe(id)->parent, id, false)) ++g.tree_edges;
  }
  for (map::KeyFrameId id : ids) {
    for (const auto& [other, weight] : map.keyframe(id)->covisibility) {
      if (weight >= min_weight && add_edge(id, other, false)) ++g.covisibility_edges;
    }
  }
  return g;
}

MapMove plan_map_move(const map::MapData& map, const EssentialGraph& graph,
                      const std::vector<SE3>& T_world_cam_optimised,
                      const std::unordered_map<map::PointId, map::KeyFrameId>& corrected_by,
                      const std::unordered_map<map::PointId, Eigen::Vector3d>& set_positions) {
  MapMove move;
  move.last_keyframe = map.last_keyframe();
  std::unordered_map<map::KeyFrameId, int> node;
  std::vector<SE3> correction(graph.ids.size());
  for (std::size_t i = 0; i < graph.ids.size(); ++i) {
    node[graph.ids[i]] = static_cast<int>(i);
    correction[i] = T_world_cam_optimised[i] * graph.T_world_cam_built[i].inverse();
  }
  // Every keyframe moves with its nearest ancestor in the graph.
  std::unordered_map<map::KeyFrameId, int> node_of_keyframe;
  std::unordered_map<map::KeyFrameId, Eigen::Vector3d> centre_after;
  map::KeyFrameId newest = map::kNoKeyFrame;
  for (const auto& [id, kf] : map.keyframes()) {
    const int n = node_of(map, id, node);
    node_of_keyframe[id] = n;
    newest = std::max(newest, id);
    if (n < 0) continue;
    const SE3 T_world_cam = correction[static_cast<std::size_t>(n)] * kf.T_world_cam;
    move.T_world_cam.emplace_back(id, T_world_cam);
    centre_after[id] = T_world_cam.translation();
  }
  if (const auto it = node_of_keyframe.find(newest); it != node_of_keyframe.end() && it->second >= 0) {
    move.newest_correction = correction[static_cast<std::size_t>(it->second)];
  }
  const auto centre_of = [&](const map::KeyFrame& kf) {
    const auto it = centre_after.find(kf.id);
    return it != centre_after.end() ? it->second : kf.camera_center();
  };
  // Each point: the position it is given, else moved with the keyframe it
  // follows; its geometry from the moved keyframes.
  for (const auto& [pid, p] : map.points()) {
    if (p.bad) continue;
    Eigen::Vector3d p_world;
    if (const auto given = set_positions.find(pid); given != set_positions.end()) {
      p_world = given->second;
      ++move.points_set;
    } else {
      const auto by = corrected_by.find(pid);
      const map::KeyFrameId ref =
          by != corrected_by.end() && node.count(by->second) != 0 ? by->second : p.reference_keyframe;
      const auto it = node_of_keyframe.find(ref);
      if (it == node_of_keyframe.end() || it->second < 0) continue;
      p_world = correction[static_cast<std::size_t>(it->second)] * p.p_world;
    }
    move.points.push_back(
        {pid, p_world, map.point_geometry(pid, p_world, centre_of).value_or(map::PointGeometry{})});
  }
  return move;
}

GraphApplied commit_map_move(map::MapData& map, const MapMove& move) {
  GraphApplied out;
  out.newest_correction = move.newest_correction;
  // Everything planned still exists (the caller planned again if the map
  // changed); the checks only keep a broken promise from crashing.
  for (const auto& [id, T_world_cam] : move.T_world_cam) {
    if (map::KeyFrame* kf = map.keyframe(id); kf != nullptr) {
      kf->T_world_cam = T_world_cam;
      ++out.keyframes_moved;
    }
  }
  for (const MapMove::Point& moved : move.points) {
    if (map::MapPoint* p = map.point(moved.id); p != nullptr) {
      p->p_world = moved.p_world;
      map.set_point_geometry(moved.id, moved.geometry);
    }
  }
  out.points_set = move.points_set;
  out.points_moved = static_cast<int>(move.points.size()) - move.points_set;
  return out;
}

GraphApplied apply_essential_graph(map::MapData& map, const EssentialGraph& graph,
                                   const std::vector<SE3>& T_world_cam_optimised,
                                   const std::unordered_map<map::PointId, map::KeyFrameId>& corrected_by) {
  return commit_map_move(map, plan_map_move(map, graph, T_world_cam_optimised, corrected_by, {}));
}

}  // namespace sitepose::loop
