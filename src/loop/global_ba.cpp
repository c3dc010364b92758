#include "sitepose/loop/global_ba.hpp"

namespace sitepose::loop {

MapMove plan_global_ba_move(const map::MapData& map, const mapping::LocalBaProblem& problem,
                            const optim::LocalBaResult& result) {
  // The keyframes move as the essential graph's nodes do: by the correction
  // of themselves or of their nearest ancestor in the copy; the copy's
  // points take the solve's positions, points made since move with their
  // reference keyframe.
  EssentialGraph copied;
  std::vector<SE3> T_world_cam_optimised;
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    copied.ids.push_back(problem.keyframe_ids[k]);
    copied.T_world_cam_built.push_back(problem.input.T_cam_world[k].inverse());
    T_world_cam_optimised.push_back(result.T_cam_world[k].inverse());
  }
  std::unordered_map<map::PointId, Eigen::Vector3d> optimised;
  for (std::size_t pi = 0; pi < problem.point_ids.size(); ++pi)
    optimised[problem.point_ids[pi]] = result.p_world[pi];
  return plan_map_move(map, copied, T_world_cam_optimised, {}, optimised);
}

GlobalBaApplied apply_global_ba(map::MapData& map, const mapping::LocalBaProblem& problem,
                                const optim::LocalBaResult& result) {
  const GraphApplied applied = commit_map_move(map, plan_global_ba_move(map, problem, result));
  GlobalBaApplied out;
  out.keyframes_moved = applied.keyframes_moved;
  out.points_optimised = applied.points_set;
  out.newest_correction = applied.newest_correction;
  return out;
}

}  // namespace sitepose::loop
