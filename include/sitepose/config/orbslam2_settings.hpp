#pragma once
// ORB-SLAM2 stereo settings files (OpenCV FileStorage YAML, `%YAML:1.0`), so
// users of ORB-SLAM2 can bring the file they already have.
//
// Read keys (all numbers; ints where ORB-SLAM2 reads ints):
//   required: Camera.fx Camera.fy Camera.cx Camera.cy Camera.width
//             Camera.height Camera.fps Camera.bf ThDepth
//             ORBextractor.nFeatures .scaleFactor .nLevels .iniThFAST .minThFAST
//   optional: Camera.k1 Camera.k2 Camera.p1 Camera.p2 Camera.k3 (must be 0:
//             sitepose takes rectified images), Camera.RGB (0 or 1)
// baseline_m = Camera.bf / Camera.fx; ThDepth is in baselines, as in
// ORB-SLAM2 (close points are nearer than ThDepth * baseline).
// Keys sitepose does not use (Viewer.*, ...) are listed in ignored_keys for
// the caller to log. Files with rectification maps (LEFT.K, RIGHT.P, ...:
// ORB-SLAM2's EuRoC stereo files) are kUnsupported: rectify first.
//
// Errors name the file and the key: kNotFound (no file), kParseError
// (malformed file; OpenCV's message kept), kInvalidArgument (missing key,
// wrong type, value out of range). Pure functions, any thread.

#include <string>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::config {

struct OrbSlam2Settings {
  StereoCamera camera;                    // rectified pinhole pair, validated
  OrbConfig orb;                          // grid_cell_px keeps its default (not in the file)
  double close_depth_baselines = 0;       // ThDepth
  double fps_hz = 0;                      // Camera.fps
  bool rgb = false;                       // Camera.RGB: colour images are RGB (else BGR; absent = BGR)
  std::vector<std::string> ignored_keys;  // present in the file, unused by sitepose
};

Expected<OrbSlam2Settings> load_orbslam2_settings(const std::string& path);
// Same, from the text of a file; source_name is used in messages.
Expected<OrbSlam2Settings> load_orbslam2_settings_from_string(const std::string& text,
                                                              const std::string& source_name);

// Overrides the fields the file defines: camera.stereo,
// camera.channel_order (Camera.RGB; absent = 0 = BGR, as ORB-SLAM2 reads
// it), orb (all but grid_cell_px), tracking.close_depth_baselines and
// tracking.keyframe_max_interval_frames = round(fps) (ORB-SLAM2 inserts a
// keyframe at least every fps frames). Everything else is left as it is.
void apply_orbslam2_settings(const OrbSlam2Settings& settings, SiteposeConfig& config);

}  // namespace sitepose::config
