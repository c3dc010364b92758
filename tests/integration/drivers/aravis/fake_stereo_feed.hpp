#pragma once
// The Aravis fake-camera tests' shared pieces: the in-process fake stereo
// pair (drivers/aravis/fake_stereo_feed.hpp) and the ideal rig's
// calibration file.

#include <arv.h>

#include <opencv2/core.hpp>
#include <opencv2/core/persistence.hpp>
#include <string>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/drivers/aravis/fake_stereo_feed.hpp"
#include "sitepose/drivers/aravis/pixel_convert.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::testing {

using drivers::aravis::FakeStereoFeed;

// The rig's calibration as `sitepose calibrate` writes it (an ideal pair:
// no distortion, no rotation), in `dir`/stereo.yaml.
inline std::string write_calibration(const TempDir& dir, const StereoCamera& c) {
  const std::string path = dir / "stereo.yaml";
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  fs << "K1" << K << "D1" << cv::Mat::zeros(1, 5, CV_64F) << "K2" << K << "D2"
     << cv::Mat::zeros(1, 5, CV_64F);
  fs << "R" << cv::Mat::eye(3, 3, CV_64F) << "T" << (cv::Mat_<double>(3, 1) << -c.baseline_m, 0, 0);
  fs << "image_width" << c.width << "image_height" << c.height;
  return path;
}

}  // namespace sitepose::testing
