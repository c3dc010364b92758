#pragma once
// A synthetic map with a real loop in it, for the loop closer's test and
// `sitepose bench loop`: a camera drives along a textured wall (points 6-10 m
// in front of it) one keyframe a metre and back. Out, the map is exact; at
// the turn the return still sees the outbound points, one keyframe later
// half of them, after that none: the return builds its own (duplicate)
// points from odometry that drifts 0.1 degrees of heading and 1 cm a
// keyframe. Back at the start, only place recognition can join the two.
// The observations are exact (no pixel noise), so a global BA after the
// pose graph can find the truth.
//
// Frames: world = the first keyframe's camera (x along the lane, z towards
// the wall); units metres.

#include <cstdint>
#include <memory>
#include <vector>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/map/map_data.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace sitepose::experiments {

struct TexturedWall {
  std::vector<Eigen::Vector3d> p_world_m;
  std::vector<map::Descriptor> descriptors;  // random: each point its own
};

// `points` points over x in [-8, lane_m + 8], y in [-2, 2], z in [6, 10].
TexturedWall make_textured_wall(std::uint64_t seed, double lane_m, int points = 6000);

// The camera at x_m along the lane, looking at the wall.
SE3 lane_camera_at(double x_m);

// Inserts a keyframe truly at T_true, stored at T_map, with every wall point
// it sees; point_of_wall_point maps a wall point to its map point on this
// side (created here, at T_map's view of it, when kNoPoint).
map::KeyFrameId insert_wall_keyframe(map::MapData& map, const StereoCamera& camera, const TexturedWall& wall,
                                     const SE3& T_true, const SE3& T_map,
                                     std::vector<map::PointId>& point_of_wall_point);

struct DriftedReturn {
  map::MapData map;  // appearance and covisibility updated
  std::vector<map::KeyFrameId> outbound;
  std::vector<map::KeyFrameId> inbound;  // the returning keyframes, the last back at the start
  std::vector<SE3> inbound_truth;        // T_world_cam of each returning keyframe
};

// Out for lane_keyframes keyframes (0 .. lane_keyframes - 1 m) and back.
// Each keyframe's map_travel_m is the path to it (a metre a keyframe), as
// the tracker keeps it on a return that does not find the outbound points.
DriftedReturn make_drifted_return(const StereoCamera& camera, const TexturedWall& wall, int lane_keyframes);

// A small vocabulary (3 levels) trained on the keyframes' own descriptors.
Expected<std::shared_ptr<const placerec::Vocabulary>> vocabulary_of(const map::MapData& map);

// Position error of keyframe `id` against its truth.
double keyframe_error_m(const map::MapData& map, map::KeyFrameId id, const SE3& truth);

// RMS position error of the returning keyframes in `map` (the return's map
// or a corrected copy of it).
double return_rms_error_m(const map::MapData& map, const DriftedReturn& loop);

}  // namespace sitepose::experiments
