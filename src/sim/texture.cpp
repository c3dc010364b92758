#include "sitepose/sim/texture.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "sitepose/core/expected.hpp"

namespace sitepose::sim {

Texture::Texture(const cv::Mat& image, TextureWrap wrap) : wrap_(wrap) {
  SITEPOSE_CHECK(image.type() == CV_8UC1 && !image.empty());
  if (wrap == TextureWrap::kRepeat) {
    // Power-of-two tiles let sample() wrap with a mask.
    SITEPOSE_CHECK((image.cols & (image.cols - 1)) == 0 && (image.rows & (image.rows - 1)) == 0);
  }
  levels_.push_back(image.clone());
  while (levels_.back().cols >= 8 && levels_.back().rows >= 8) {
    cv::Mat half;
    cv::resize(levels_.back(), half, cv::Size(levels_.back().cols / 2, levels_.back().rows / 2), 0,
               0, cv::INTER_AREA);
    levels_.push_back(half);
  }
}

}  // namespace sitepose::sim
