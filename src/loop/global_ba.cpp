#include "sitepose/loop/global_ba.hpp"

#include "sitepose/loop/loop_correction.hpp"

#include <unordered_set>

namespace sitepose::loop {

GlobalBaApplied apply_global_ba(map::MapData& map, const mapping::LocalBaProblem& problem,
                                const optim::LocalBaResult& result) {
  // The keyframes move as the essential graph's nodes do: by the correction
  // of themselves or of their nearest ancestor in the copy, points with
  // their reference keyframe.
  EssentialGraph copied;
  std::vector<SE3> T_world_cam_optimised;
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    copied.ids.push_back(problem.keyframe_ids[k]);
    copied.T_world_cam_built.push_back(problem.input.T_cam_world[k].inverse());
    T_world_cam_optimised.push_back(result.T_cam_world[k].inverse());
  }
  // The copy's points are set to the solve's positions below, so the graph
  // moves only those made since.
  const std::unordered_set<map::PointId> optimised(problem.point_ids.begin(), problem.point_ids.end());
  const GraphApplied moved = apply_essential_graph(map, copied, T_world_cam_optimised, {}, &optimised);
  GlobalBaApplied out;
  out.keyframes_moved = moved.keyframes_moved;
  out.newest_correction = moved.newest_correction;
  for (std::size_t pi = 0; pi < problem.point_ids.size(); ++pi) {
    map::MapPoint* p = map.point(problem.point_ids[pi]);
    if (p == nullptr || p->bad) continue;
    p->p_world = result.p_world[pi];
    map.update_point_geometry(p->id);
    ++out.points_optimised;
  }
  return out;
}

}  // namespace sitepose::loop
