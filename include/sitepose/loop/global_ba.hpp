#pragma once
// Global bundle adjustment after a loop closure (ORB-SLAM2
// LoopClosing::RunGlobalBundleAdjustment): the pose graph spreads the loop's
// error over the keyframes; the global BA then refines every keyframe and
// point against their observations.
//   1. copy: the whole map (mapping::build_global_ba_problem) under the read
//      lock, the first keyframe held fixed;
//   2. solve: optim::LocalBa (Huber stage, then the inliers) without any
//      lock; a stop flag ends it early with the last accepted iterate;
//   3. apply (plan_global_ba_move under the read lock, then commit_map_move
//      under the write lock; apply_global_ba does both), the mapper paused:
//      each keyframe of the copy takes its optimised pose, a keyframe made
//      since moves with its nearest ancestor in the copy (spanning tree);
//      each point of the copy takes its optimised position, a point made
//      since moves with its reference keyframe. Observations are kept (the
//      solve's outliers are not erased, as in ORB-SLAM2).
// Thread: free functions on values; the caller holds the locks named above.

#include "sitepose/core/se3.hpp"
#include "sitepose/loop/loop_correction.hpp"
#include "sitepose/map/map_data.hpp"
#include "sitepose/mapping/local_ba_problem.hpp"
#include "sitepose/optim/local_ba.hpp"

namespace sitepose::loop {

struct GlobalBaApplied {
  int keyframes_moved = 0;   // of the copy and made since
  int points_optimised = 0;  // of the copy, set to the solve's positions
  // T_world' * T_world^-1 of the newest keyframe: what moves the tracker's
  // last pose with the map.
  SE3 newest_correction;
};

// Step 3 in two halves (loop_correction.hpp, MapMove): planned under the
// read lock, committed under the write lock.
MapMove plan_global_ba_move(const map::MapData& map, const mapping::LocalBaProblem& problem,
                            const optim::LocalBaResult& result);
// Both halves under one (write) lock.
GlobalBaApplied apply_global_ba(map::MapData& map, const mapping::LocalBaProblem& problem,
                                const optim::LocalBaResult& result);

}  // namespace sitepose::loop
