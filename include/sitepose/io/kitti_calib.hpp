#pragma once
// KITTI-style calib.txt of a rectified stereo pair (FORMATS.md):
//   P0: fx 0 cx 0  0 fy cy 0  0 0 1 0
//   P1: fx 0 cx -fx*b  0 fy cy 0  0 0 1 0
// Other keys (KITTI's P2, P3, Tr, ...) are accepted and ignored.

#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::io {

// Returns fx, fy, cx, cy and baseline_m = -P1[0][3] / fx; width and height
// stay 0 (they come from the images). Errors (kParseError) name the file and
// line: a line not "KEY: numbers", P0/P1 without 12 numbers, a repeated key,
// a missing P0 or P1, P1 intrinsics differing from P0 (not rectified), a
// non-zero P0 translation, or a baseline that is not positive.
Expected<StereoCamera> read_kitti_calib(const std::string& path);

}  // namespace sitepose::io
