#pragma once
// Loop correction on the map (ORB-SLAM2 LoopClosing::CorrectLoop and
// Optimizer::OptimizeEssentialGraph, stereo: SE(3)), in steps that follow
// the map's lock rule (map/shared_map.hpp): copies under read(), searches
// and the solve without a lock, short updates under write().
//
//   1. copy_group (read): the current keyframe, its covisible keyframes (the
//      "group") and their good points;
//   2. plan_group_correction (no lock): each group keyframe moved rigidly
//      with the current one, T_world_i' = T_world_cur' * T_cur_world *
//      T_world_i; each group point moved with the first group keyframe
//      that observes it; the loop side's points searched in the moved
//      group keyframes (mapping/fuse.hpp) to find the duplicates;
//   3. apply_group_correction (write): the poses and points set (and
//      those of keyframes inserted since step 1, by the same C), the
//      duplicates fused with the loop side's point kept (the map around
//      the loop is the older, better-anchored one); then
//      count_group_connections (read) and connect_group (write): the fused
//      points' descriptors and the group's covisibility, counted under the
//      read lock and set under a second short write lock (counted again
//      there if the tracker inserted a keyframe in between), and the new
//      covisibility links the fusion made ("loop connections") found;
//   4. build_essential_graph (read): nodes = every keyframe; edges = the
//      spanning tree, covisibility links of weight >= min_weight, every
//      loop edge, and the new loop connections of weight >= min_weight.
//      Measurements are the relative poses before step 3 (what odometry
//      measured), except the new loop's edges, measured after it; the
//      map's first keyframe is fixed;
//   5. optimise_pose_graph (pose_graph.hpp; no lock);
//   6. plan_map_move (read), then commit_map_move (write): each keyframe
//      gets its optimised pose (one created since step 4 moves with its
//      nearest ancestor in the graph); each point moves with the keyframe
//      it was corrected by in step 2, else its reference keyframe: p' =
//      T_world_k' * T_world_k^-1 * p (apply_essential_graph does both
//      under one lock).

#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/loop/loop_verifier.hpp"
#include "sitepose/loop/pose_graph.hpp"
#include "sitepose/map/map_data.hpp"
#include "sitepose/mapping/fuse.hpp"

namespace sitepose::loop {

using KeyFramePair = std::pair<map::KeyFrameId, map::KeyFrameId>;

struct GroupCopy {
  std::vector<mapping::KeyFrameSnapshot> keyframes;  // the current keyframe first
  std::vector<mapping::PointSnapshot> points;
  std::unordered_map<map::KeyFrameId, SE3>
      T_world_cam_all;  // every keyframe of the map, before the correction
  std::unordered_map<map::KeyFrameId, std::vector<map::KeyFrameId>> covisible_before;  // of the group
};

GroupCopy copy_group(const map::MapData& map, map::KeyFrameId current);

struct GroupCorrection {
  map::KeyFrameId current = map::kNoKeyFrame;
  map::KeyFrameId loop = map::kNoKeyFrame;
  SE3 correction;  // C = T_world_cur' * T_cur_world: T_world' = C * T_world for the group
  std::unordered_map<map::KeyFrameId, SE3> T_world_cam;            // of the group, corrected
  std::unordered_map<map::PointId, Eigen::Vector3d> p_world;       // of the group's points, corrected
  std::unordered_map<map::PointId, map::KeyFrameId> corrected_by;  // which group keyframe moved a point
  std::vector<mapping::FuseProposal> fusions;                      // loop points -> group keypoints
};

GroupCorrection plan_group_correction(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                      const GroupCopy& group, const VerifiedLoop& loop,
                                      const std::vector<mapping::PointSnapshot>& loop_points);

struct GroupApplied {
  int keyframes_moved = 0;
  int points_moved = 0;
  int points_fused = 0;        // a group point replaced by a loop point
  int observations_added = 0;  // a loop point seen by a group keypoint that had none
  std::unordered_set<map::PointId>
      points_with_new_views;                   // loop points fused into: connect_group refreshes them
  std::vector<KeyFramePair> loop_connections;  // (group keyframe, newly covisible keyframe): connect_group
  // Keyframes the tracker inserted since copy_group, and the points created
  // with them, moved with the group (they were placed in its old frame).
  std::unordered_map<map::PointId, map::KeyFrameId> corrected_by;
};

GroupApplied apply_group_correction(map::MapData& map, const GroupCopy& group, const GroupCorrection& plan);

// After apply_group_correction, under the same lock: the corrected group
// now lies on the map made at `loop_keyframe` (its duplicates fused into
// that side's points), so its keyframes' map travel (the published drift
// term's distance, map::map_travel_at) becomes the loop keyframe's plus the
// straight distance from it where that is less. Keyframes the pose graph
// moves later keep theirs (conservative).
void tie_map_travel_to_loop(map::MapData& map, const GroupCorrection& plan, map::KeyFrameId loop_keyframe);

// What connect_group sets, counted under the read lock.
struct GroupConnections {
  map::KeyFrameId last_keyframe = map::kNoKeyFrame;  // the map's newest when counted
  std::vector<std::pair<map::PointId, map::Descriptor>> descriptors;
  std::vector<std::pair<map::KeyFrameId, map::MapData::SharedPointCounts>> shared_points;
};

GroupConnections count_group_connections(const map::MapData& map, const GroupCorrection& plan,
                                         const GroupApplied& applied);
void connect_group(map::MapData& map, const GroupCopy& group, const GroupCorrection& plan,
                   const GroupConnections& counted, GroupApplied& applied);

struct EssentialGraph {
  std::vector<map::KeyFrameId> ids;    // node -> keyframe
  std::vector<SE3> T_world_cam_built;  // node poses when built (step 4)
  PoseGraphInput input;
  int tree_edges = 0;
  int covisibility_edges = 0;
  int loop_edges = 0;
};

// `measured_before`: the poses before the correction (GroupCopy::
// T_world_cam_all); `new_edges`: the new loop edge and loop connections,
// measured at the current poses.
EssentialGraph build_essential_graph(const map::MapData& map,
                                     const std::unordered_map<map::KeyFrameId, SE3>& measured_before,
                                     const std::vector<KeyFramePair>& loop_edges,
                                     const std::vector<KeyFramePair>& new_edges, int min_weight);

struct GraphApplied {
  int keyframes_moved = 0;
  int points_moved = 0;  // with a keyframe's correction
  int points_set = 0;    // to a given position (the global BA's)
  // T_world' * T_world^-1 of the newest keyframe: what moves the tracker's
  // last pose with the map.
  SE3 newest_correction;
};

// Step 6 (and the global BA's apply) in two halves, so that the work is
// done under the read lock and the write lock only assigns: plan_map_move
// computes every keyframe's new pose, every good point's new position (one
// in set_positions takes it, the others move as in step 6) and geometry;
// commit_map_move assigns them. Valid while the map has not changed in
// between: the caller plans again under the write lock when the map's
// last keyframe is no longer move.last_keyframe (the mapper is paused, so
// only the tracker's keyframe insertion can change it).
struct MapMove {
  struct Point {
    map::PointId id = map::kNoPoint;
    Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
    map::PointGeometry geometry;
  };
  map::KeyFrameId last_keyframe = map::kNoKeyFrame;  // the map's newest when planned
  std::vector<std::pair<map::KeyFrameId, SE3>> T_world_cam;
  std::vector<Point> points;
  int points_set = 0;
  SE3 newest_correction;
};

MapMove plan_map_move(const map::MapData& map, const EssentialGraph& graph,
                      const std::vector<SE3>& T_world_cam_optimised,
                      const std::unordered_map<map::PointId, map::KeyFrameId>& corrected_by,
                      const std::unordered_map<map::PointId, Eigen::Vector3d>& set_positions);
GraphApplied commit_map_move(map::MapData& map, const MapMove& move);

// Both halves under one (write) lock.
GraphApplied apply_essential_graph(map::MapData& map, const EssentialGraph& graph,
                                   const std::vector<SE3>& T_world_cam_optimised,
                                   const std::unordered_map<map::PointId, map::KeyFrameId>& corrected_by);

}  // namespace sitepose::loop
