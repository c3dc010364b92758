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

// The trajectory files `sitepose run --format` writes and `eval` reads.
//   tum    "t x y z qx qy qz qw", t in s
//   kitti  12 numbers a line (row-major 3x4), no times: the times go to a
//          sidecar, kitti_times_path(path), one per line (s)
//   euroc  "#timestamp [ns],p_RS_R_x [m],...,q_RS_w [],q_RS_x [],..." CSV
//          (state_groundtruth_estimate0/data.csv columns), t in ns
enum class TrajectoryFormat { kTum, kKitti, kEuroc };
const char* to_string(TrajectoryFormat format);
// "tum", "kitti" or "euroc"; kInvalidArgument naming the choices otherwise.
Expected<TrajectoryFormat> parse_trajectory_format(const std::string& name);
// `path` + ".times.txt".
std::string kitti_times_path(const std::string& path);

Status write_trajectory(const std::string& path, const Trajectory& trajectory, TrajectoryFormat format);

// The format of a trajectory file from its first data line: commas -> euroc,
// 12 numbers -> kitti, 8 -> tum. kParseError naming the line otherwise.
Expected<TrajectoryFormat> detect_trajectory_format(const std::string& path);

// Reads any of the three, detected; a KITTI file takes its times from
// `times_path`, or when that is empty from kitti_times_path(path).
Expected<Trajectory> read_trajectory(const std::string& path, const std::string& times_path = "");

}  // namespace sitepose::io
