#pragma once
// Gray textures with a mip pyramid, sampled bilinearly by the renderer.
// Texel (i, j) of level 0 covers [i, i+1) x [j, j+1) in texture coordinates
// (its centre is at i + 0.5); level L halves the resolution L times.
// Immutable after construction; safe to share between threads.

#include <cmath>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

namespace sitepose::sim {

enum class TextureWrap {
  kClamp,   // edge texels repeat (faces of machines and buildings)
  kRepeat,  // tiles (ground, tyre treads); level-0 size must be a power of two
};

class Texture {
 public:
  // `image` is CV_8UC1; the pyramid is built by area averaging.
  Texture(const cv::Mat& image, TextureWrap wrap);

  int width() const { return levels_.front().cols; }
  int height() const { return levels_.front().rows; }
  int level_count() const { return static_cast<int>(levels_.size()); }
  TextureWrap wrap() const { return wrap_; }

  // Bilinear value (0..255) at level-0 texture coordinates (x, y), read from
  // pyramid level `level` (clamped to the pyramid).
  // Inline: it runs once per textured pixel.
  float sample(double x, double y, int level) const {
    if (level < 0) level = 0;
    if (level >= level_count()) level = level_count() - 1;
    const cv::Mat& img = levels_[static_cast<size_t>(level)];
    const double scale = 1.0 / static_cast<double>(1 << level);
    const double fx = x * scale - 0.5;  // texel centres at i + 0.5
    const double fy = y * scale - 0.5;
    const double x0f = std::floor(fx);
    const double y0f = std::floor(fy);
    const float ax = static_cast<float>(fx - x0f);
    const float ay = static_cast<float>(fy - y0f);
    int x0 = static_cast<int>(x0f);
    int y0 = static_cast<int>(y0f);
    int x1 = x0 + 1;
    int y1 = y0 + 1;
    const int w = img.cols;
    const int h = img.rows;
    if (wrap_ == TextureWrap::kRepeat) {
      x0 &= w - 1;
      x1 &= w - 1;
      y0 &= h - 1;
      y1 &= h - 1;
    } else {
      x0 = x0 < 0 ? 0 : (x0 >= w ? w - 1 : x0);
      x1 = x1 < 0 ? 0 : (x1 >= w ? w - 1 : x1);
      y0 = y0 < 0 ? 0 : (y0 >= h ? h - 1 : y0);
      y1 = y1 < 0 ? 0 : (y1 >= h ? h - 1 : y1);
    }
    const uchar* r0 = img.ptr<uchar>(y0);
    const uchar* r1 = img.ptr<uchar>(y1);
    const float top = r0[x0] + ax * (static_cast<float>(r0[x1]) - r0[x0]);
    const float bottom = r1[x0] + ax * (static_cast<float>(r1[x1]) - r1[x0]);
    return top + ay * (bottom - top);
  }

 private:
  std::vector<cv::Mat> levels_;
  TextureWrap wrap_;
};

using TexturePtr = std::shared_ptr<const Texture>;

}  // namespace sitepose::sim
