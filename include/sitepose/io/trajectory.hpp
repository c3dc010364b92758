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

// times.txt: one timestamp (s) per line.
Expected<std::vector<double>> read_times(const std::string& path);

// KITTI poses + times.txt zipped; their line counts must agree.
Expected<Trajectory> read_kitti_trajectory(const std::string& poses_path,
                                           const std::string& times_path);

}  // namespace sitepose::io
