#pragma once
// Redundant keyframe test (ORB-SLAM2 LocalMapping::KeyFrameCulling, stereo
// case): a keyframe is redundant when at least `redundancy` of its close
// stereo map points (keypoint depth in (0, close_depth_m]) are each seen by
// at least kRedundantObservers other keyframes at the same or a finer scale
// (their keypoint octave <= this keypoint's octave + 1). Only points with an
// observation weight (map_data.hpp) above kRedundantObservers take part as
// redundant. Pure functions on MapData: call under SharedMap::read() (test)
// or write() (removal).

#include <vector>

#include "sitepose/map/map_data.hpp"

namespace sitepose::mapping {

// ORB-SLAM2 KeyFrameCulling: nObs = 3.
inline constexpr int kRedundantObservers = 3;

struct RedundancyCount {
  int close_points = 0;      // close stereo points of the keyframe
  int redundant_points = 0;  // of those, seen by >= kRedundantObservers others
};

RedundancyCount count_redundant_points(const map::MapData& map, map::KeyFrameId keyframe,
                                       double close_depth_m);

bool is_keyframe_redundant(const map::MapData& map, map::KeyFrameId keyframe, double redundancy,
                           double close_depth_m);

// The local keyframes of `current` (its n_local best covisible, the local
// BA window) that may be removed: never the map's first keyframe, never
// `current` or a keyframe inserted after it (those are still waiting in the
// mapper's queue), and only the redundant ones. Ascending ids.
// Why the window and not every covisible keyframe (ORB-SLAM2): on a site
// driven back and forth all keyframes are covisible through the far
// points, and culling them all lets the redundancy test erode the map to a
// few keyframes around the camera, dropping the points of the rest of the
// site (measured in local_mapper_test, back and forth over 10 m).
std::vector<map::KeyFrameId> redundant_keyframes(const map::MapData& map, map::KeyFrameId current,
                                                 int n_local, double redundancy, double close_depth_m);

}  // namespace sitepose::mapping
