#pragma once
// One synchronised, rectified stereo pair as it travels through the pipeline.
// Ownership: a frame is moved from stage to stage; once published it is
// treated as const (cv::Mat headers share pixels, so never write into them).

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace sitepose {

struct StereoFrame {
  std::int64_t seq = 0;          // frame index in its source, monotonic
  std::int64_t t_left_ns = 0;    // capture time of the left image
  std::int64_t t_right_ns = 0;   // capture time of the right image
  cv::Mat left;                  // CV_8UC1, rectified
  cv::Mat right;                 // CV_8UC1, rectified, same size as left
  std::string source_id;         // e.g. sequence directory or camera id

  // Frame time: the left image's capture time.
  std::int64_t t_ns() const { return t_left_ns; }
};

}  // namespace sitepose
