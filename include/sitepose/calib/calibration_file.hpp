#pragma once
// The stereo calibration file that `sitepose calibrate` writes and the camera
// sources read: OpenCV FileStorage YAML with
//   image_width, image_height        raw (unrectified) image size, px
//   K1 D1 K2 D2                      intrinsics and distortion (OpenCV model)
//   R T                              x_right = R x_left + T, T in metres
//   R1 R2 P1 P2 Q                    cv::stereoRectify output (alpha 0)
//   rms                              overall reprojection RMS of the fit, px
// R1 R2 P1 P2 Q may be left out by a hand-written file: the reader then
// computes them with cv::stereoRectify.

#include <opencv2/core.hpp>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::calib {

struct StereoCalibration {
  cv::Size image_size;        // raw images, px
  cv::Mat K1, D1, K2, D2;     // CV_64F; K 3x3, D 1xN (N = 4, 5, 8, 12 or 14)
  cv::Mat R, T;               // CV_64F 3x3 and 3x1 (metres)
  cv::Mat R1, R2, P1, P2, Q;  // CV_64F rectification (3x3, 3x3, 3x4, 3x4, 4x4)
  double rms_px = 0.0;
};

// Fills R1 R2 P1 P2 Q from K D R T and the image size (cv::stereoRectify,
// CALIB_ZERO_DISPARITY, alpha 0: only valid pixels in the rectified view).
Status compute_rectification(StereoCalibration& calibration);

// Checks shapes, types, positive focal lengths and a non-zero baseline;
// the message names the bad entry.
Status validate(const StereoCalibration& calibration);

Status write_stereo_calibration(const std::string& path, const StereoCalibration& calibration);
// Errors name the file and the missing or malformed key (kParseError,
// kNotFound for a missing file).
Expected<StereoCalibration> read_stereo_calibration(const std::string& path);

// The rectified rig the frames of a camera source are in: fx fy cx cy from
// P1, baseline_m = -P2(0,3) / P2(0,0), the raw image size.
Expected<StereoCamera> rectified_camera(const StereoCalibration& calibration);

}  // namespace sitepose::calib
