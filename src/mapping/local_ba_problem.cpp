#include "sitepose/mapping/local_ba_problem.hpp"

#include <algorithm>
#include <unordered_map>

namespace sitepose::mapping {

namespace {

void add_keyframe(const map::MapData& map, map::KeyFrameId id, bool fixed, LocalBaProblem& problem,
                  std::unordered_map<map::KeyFrameId, int>& keyframe_index) {
  keyframe_index[id] = static_cast<int>(problem.keyframe_ids.size());
  problem.keyframe_ids.push_back(id);
  problem.input.T_cam_world.push_back(map.keyframe(id)->T_cam_world());
  problem.input.keyframe_fixed.push_back(fixed ? 1 : 0);
}

// The good points the given keyframes observe, each once, in keyframe then
// keypoint order.
void add_points_of(const map::MapData& map, const std::vector<map::KeyFrameId>& keyframes,
                   LocalBaProblem& problem) {
  std::unordered_map<map::PointId, int> point_index;
  for (map::KeyFrameId id : keyframes) {
    for (map::PointId pid : map.keyframe(id)->point_of_keypoint) {
      const map::MapPoint* p = map.good_point(pid);
      if (p == nullptr || point_index.count(pid) != 0) continue;
      point_index[pid] = static_cast<int>(problem.point_ids.size());
      problem.point_ids.push_back(pid);
      problem.input.p_world.push_back(p->p_world);
    }
  }
}

// Every observation of the problem's points by the problem's keyframes, and
// the free / fixed counts.
void add_observations(const map::MapData& map, const std::unordered_map<map::KeyFrameId, int>& keyframe_index,
                      LocalBaProblem& problem) {
  for (std::uint8_t f : problem.input.keyframe_fixed) {
    (f != 0 ? problem.n_fixed_keyframes : problem.n_free_keyframes) += 1;
  }
  for (std::size_t pi = 0; pi < problem.point_ids.size(); ++pi) {
    for (const auto& [kf_id, index] : map.point(problem.point_ids[pi])->observations) {
      const auto it = keyframe_index.find(kf_id);
      if (it == keyframe_index.end()) continue;
      const map::KeyPointData& kp = map.keyframe(kf_id)->keypoints[index];
      const double scale = map.pyramid().scale(kp.octave);
      optim::LocalBaObservation o;
      o.keyframe_index = it->second;
      o.point_index = static_cast<int>(pi);
      o.uv_left_px = kp.uv_px;
      o.u_right_px = kp.u_right_px;
      o.sigma2_px2 = scale * scale;
      problem.input.observations.push_back(o);
      problem.keypoint_of_observation.push_back(index);
    }
  }
}

}  // namespace

LocalBaProblem build_local_ba_problem(const map::MapData& map, map::KeyFrameId keyframe, int n_covisible,
                                      int max_fixed) {
  LocalBaProblem problem;
  if (map.keyframe(keyframe) == nullptr) return problem;
  const map::KeyFrameId first = map.first_keyframe();

  std::unordered_map<map::KeyFrameId, int> keyframe_index;
  std::vector<map::KeyFrameId> window{keyframe};
  for (map::KeyFrameId id : map.best_covisible(keyframe, n_covisible)) {
    const map::KeyFrame* kf = map.keyframe(id);
    if (kf != nullptr && !kf->bad) window.push_back(id);
  }
  for (map::KeyFrameId id : window) add_keyframe(map, id, id == first, problem, keyframe_index);
  add_points_of(map, window, problem);

  // Fixed ring: keyframes outside the window ranked by how many window points they see.
  std::unordered_map<map::KeyFrameId, int> outside_count;
  for (map::PointId pid : problem.point_ids) {
    for (const auto& [kf_id, index] : map.point(pid)->observations) {
      if (keyframe_index.count(kf_id) == 0 && map.keyframe(kf_id) != nullptr) ++outside_count[kf_id];
    }
  }
  std::vector<std::pair<int, map::KeyFrameId>> ranked;
  ranked.reserve(outside_count.size());
  for (const auto& [id, count] : outside_count) ranked.emplace_back(count, id);
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  std::vector<map::KeyFrameId> fixed;
  if (outside_count.count(first) != 0) fixed.push_back(first);
  for (const auto& [count, id] : ranked) {
    if (static_cast<int>(fixed.size()) >= max_fixed) break;
    if (id != first) fixed.push_back(id);
  }
  for (map::KeyFrameId id : fixed) add_keyframe(map, id, true, problem, keyframe_index);

  const bool any_fixed = std::any_of(problem.input.keyframe_fixed.begin(), problem.input.keyframe_fixed.end(),
                                     [](std::uint8_t f) { return f != 0; });
  if (!any_fixed && !problem.keyframe_ids.empty()) {
    const auto oldest = std::min_element(problem.keyframe_ids.begin(), problem.keyframe_ids.end());
    problem.input.keyframe_fixed[oldest - problem.keyframe_ids.begin()] = 1;
  }
  add_observations(map, keyframe_index, problem);
  return problem;
}

LocalBaProblem build_global_ba_problem(const map::MapData& map) {
  LocalBaProblem problem;
  std::vector<map::KeyFrameId> all;
  for (const auto& [id, kf] : map.keyframes()) {
    if (!kf.bad) all.push_back(id);
  }
  std::sort(all.begin(), all.end());
  std::unordered_map<map::KeyFrameId, int> keyframe_index;
  for (map::KeyFrameId id : all) add_keyframe(map, id, id == map.first_keyframe(), problem, keyframe_index);
  add_points_of(map, all, problem);
  add_observations(map, keyframe_index, problem);
  return problem;
}

LocalBaApplied apply_local_ba(map::MapData& map, const LocalBaProblem& problem,
                              const optim::LocalBaResult& result) {
  LocalBaApplied applied;
  for (int i : result.outlier_observations) {
    const optim::LocalBaObservation& o = problem.input.observations[i];
    const map::PointId pid = problem.point_ids[o.point_index];
    const map::KeyFrameId kf_id = problem.keyframe_ids[o.keyframe_index];
    const map::MapPoint* p = map.good_point(pid);
    if (p == nullptr) continue;
    // Only the association the solve judged: it may have changed meanwhile.
    const auto it = p->observations.find(kf_id);
    if (it == p->observations.end() || it->second != problem.keypoint_of_observation[i]) continue;
    map.erase_observation(pid, kf_id);
    ++applied.outliers_erased;
  }
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    if (problem.input.keyframe_fixed[k] != 0) continue;
    map::KeyFrame* kf = map.keyframe(problem.keyframe_ids[k]);
    if (kf == nullptr || kf->bad) continue;
    kf->T_world_cam = result.T_cam_world[k].inverse();
    ++applied.keyframes_updated;
  }
  for (std::size_t pi = 0; pi < problem.point_ids.size(); ++pi) {
    map::MapPoint* p = map.point(problem.point_ids[pi]);
    if (p == nullptr || p->bad) continue;
    p->p_world = result.p_world[pi];
    map.update_point_geometry(p->id);  // views unchanged: the descriptor stays
    ++applied.points_updated;
  }
  return applied;
}

}  // namespace sitepose::mapping
