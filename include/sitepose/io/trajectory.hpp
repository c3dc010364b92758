#pragma once
// Trajectory files (FORMATS.md "Trajectories written by sitepose").
// All poses are T_world_cam of the LEFT camera.

#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"

namespace sitepose::io {

struct StampedPose {
  double t_s = 0.0;
  SE3 T_world_cam;
};

using Trajectory = std::vector<StampedPose>;

// TUM: "t x y z qx qy qz qw" per line, '#' comments and blank lines allowed.
Expected<Trajectory> read_tum_trajectory(const std::string& path);
Status write_tum_trajectory(const std::string& path, const Trajectory& trajectory);

// KITTI poses: 12 numbers per line (row-major 3x4), no timestamps.
Expected<std::vector<SE3>> read_kitti_poses(const std::string& path);
Status write_kitti_poses(const std::string& path, const std::vector<SE3>& poses);

// Largest time a times.txt may hold (s): the year 2096 as Unix time, well
// inside int64 nanoseconds.
inline constexpr double kMaxTimeS = 4e9;

// times.txt: one timestamp (s) per line, each in 0..kMaxTimeS and at least
// 1 ns after the one before (frames are stamped in int64 ns); errors
// (kParseError) name "path:line".
Expected<std::vector<double>> read_times(const std::string& path);

// KITTI poses + times.txt zipped; their line counts must agree.
Expected<Trajectory> read_kitti_trajectory(const std::string& poses_path,
                                           const std::string& times_path);

}  // namespace sitepose::io
