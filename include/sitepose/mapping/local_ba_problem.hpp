#pragma once
// The local BA window of a keyframe (ORB-SLAM2 Optimizer::
// LocalBundleAdjustment): copied out of the map under SharedMap::read(),
// solved by optim::LocalBa without any lock, written back under
// SharedMap::write().
//
// Window: the keyframe and its best `n_covisible` covisible keyframes are
// optimised; their good points are optimised; keyframes outside the window
// that observe those points are held fixed (the `max_fixed` that observe
// most of them, always including the map's first keyframe when it observes
// any). The map's first keyframe is held fixed when it is in the window
// (it anchors the gauge); when no keyframe is fixed at all the oldest
// window keyframe is, so the solve never drifts freely.

#include <vector>

#include "sitepose/map/map_data.hpp"
#include "sitepose/optim/local_ba.hpp"

namespace sitepose::mapping {

struct LocalBaProblem {
  optim::LocalBaInput input;
  std::vector<map::KeyFrameId> keyframe_ids;  // per input keyframe
  std::vector<map::PointId> point_ids;        // per input point
  std::vector<int> keypoint_of_observation;   // per input observation: keypoint index in its keyframe
  int n_free_keyframes = 0;
  int n_fixed_keyframes = 0;
};

// Builds the window of `keyframe` (call under SharedMap::read()); an empty
// problem when the keyframe is gone.
LocalBaProblem build_local_ba_problem(const map::MapData& map, map::KeyFrameId keyframe, int n_covisible,
                                      int max_fixed);

// The whole map (ORB-SLAM2 Optimizer::GlobalBundleAdjustemnt): every good
// keyframe, the map's first one held fixed (the gauge), and every good point
// they observe (call under SharedMap::read()).
LocalBaProblem build_global_ba_problem(const map::MapData& map);

struct LocalBaApplied {
  int outliers_erased = 0;
  int keyframes_updated = 0;
  int points_updated = 0;
};

// Writes the result back (call under SharedMap::write()): erases the
// observations the solve rejected (when still the same keypoint), then sets
// the poses of the free keyframes and the positions of the points that still
// exist and are good, and refreshes their normal and scale range.
LocalBaApplied apply_local_ba(map::MapData& map, const LocalBaProblem& problem,
                              const optim::LocalBaResult& result);

}  // namespace sitepose::mapping
