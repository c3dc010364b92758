#pragma once
// EuRoC MAV (ASL) building blocks, exposed for tests and tools; sequences are
// opened with open_sequence() (sequence.hpp).
// Frames: B = body (IMU), cam0 / cam1 = raw cameras, rect = rectified left
// camera (the StereoCamera's frame), world = the GT's R frame.
// Pure functions, thread-compatible.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::io {

// One camera's sensor.yaml (pinhole, radial-tangential).
struct EurocCameraSensor {
  double fu = 0.0, fv = 0.0, cu = 0.0, cv = 0.0;  // intrinsics, px
  std::array<double, 4> distortion{};              // k1 k2 p1 p2
  int width = 0, height = 0;                       // resolution, px
  SE3 T_body_cam;                                  // T_BS
};

// Parses sensor.yaml with yaml-cpp (the "%YAML:1.0" first line of the real
// files, which yaml-cpp rejects, is blanked; line numbers stay true).
// Requires camera_model "pinhole", distortion_model "radial-tangential",
// intrinsics [fu fv cu cv], distortion_coefficients [k1 k2 p1 p2],
// resolution [w h], T_BS {rows: 4, cols: 4, data: 16 numbers row-major}
// with a rotation block and last row 0 0 0 1. Errors name file, line, key.
Expected<EurocCameraSensor> read_euroc_sensor_yaml(const std::string& path);

// Stereo rectification computed once per sequence: cv::stereoRectify with
// CALIB_ZERO_DISPARITY and alpha 0, then initUndistortRectifyMap per camera.
struct EurocRectification {
  StereoCamera camera;   // fx, fy, cx, cy of P1; baseline_m = -P2[0][3] / P2[0][0]
  SE3 T_cam0_rect;       // rotation R1^T: p_cam0 = T_cam0_rect * p_rect
  SE3 T_cam1_rect_right; // rotation R2^T, for the right rectified camera
  cv::Mat map0_a, map0_b;  // cv::remap tables, left  (CV_16SC2 + CV_16UC1)
  cv::Mat map1_a, map1_b;  // cv::remap tables, right
};

// kInvalidArgument when the resolutions differ or cam1 is not to the right
// of cam0 (a vertical or swapped pair).
Expected<EurocRectification> make_euroc_rectification(const EurocCameraSensor& cam0,
                                                      const EurocCameraSensor& cam1);

// A row of mav0/cam*/data.csv: "timestamp_ns,filename".
struct EurocImageEntry {
  std::int64_t t_ns = 0;
  std::string file_name;
};
// '#' header lines skipped; timestamps must strictly increase.
Expected<std::vector<EurocImageEntry>> read_euroc_image_list(const std::string& path);

// A row of state_groundtruth_estimate0/data.csv: timestamp ns, p_RS_R (m),
// q_RS (w x y z), further columns ignored. T_world_body = (q_RS, p_RS_R).
struct EurocGtSample {
  std::int64_t t_ns = 0;
  SE3 T_world_body;
};
Expected<std::vector<EurocGtSample>> read_euroc_groundtruth(const std::string& path);

// T_world_rect at each time: T_world_body(t) * T_body_rect, T_world_body
// interpolated (core's interpolate()) between the bracketing samples, which
// must be at most max_gap_ns apart. nullopt outside the GT span or in a gap.
// `samples` sorted by time.
std::vector<std::optional<SE3>> euroc_gt_at_times(const std::vector<EurocGtSample>& samples,
                                                  const std::vector<std::int64_t>& times_ns,
                                                  const SE3& T_body_rect, std::int64_t max_gap_ns);

}  // namespace sitepose::io
