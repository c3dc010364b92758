#pragma once
// Generated test images: textures, shape scenes, rectified right images of
// known disparity (no data files). Needs OpenCV imgproc.

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace sitepose::testing {

// Dense corner texture: random grey blocks of block_px, slightly blurred so
// sub-pixel resampling is well defined. Deterministic for a seed.
inline cv::Mat make_texture(cv::Size size, std::uint64_t seed, int block_px = 4, double blur_sigma = 1.0) {
  cv::RNG rng(seed);
  cv::Mat blocks((size.height + block_px - 1) / block_px, (size.width + block_px - 1) / block_px, CV_8UC1);
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::Mat big;
  cv::resize(blocks, big, cv::Size(blocks.cols * block_px, blocks.rows * block_px), 0, 0, cv::INTER_NEAREST);
  cv::Mat image = big(cv::Rect(0, 0, size.width, size.height)).clone();
  if (blur_sigma > 0) cv::GaussianBlur(image, image, cv::Size(0, 0), blur_sigma);
  return image;
}

// A scene of random grey rectangles and discs (4..30 px) over a faint block
// texture: distinct, repeatable corners like man-made structure.
inline cv::Mat make_shapes_scene(cv::Size size, std::uint64_t seed, int n_shapes = 3000) {
  cv::RNG rng(seed);
  cv::Mat image = make_texture(size, seed + 1, 4, 1.0);
  image.convertTo(image, CV_8UC1, 0.15, 128.0 * 0.85);  // faint background
  for (int i = 0; i < n_shapes; ++i) {
    const cv::Point corner(rng.uniform(0, size.width), rng.uniform(0, size.height));
    const int w = rng.uniform(4, 30);
    const int h = rng.uniform(4, 30);
    const cv::Scalar grey(rng.uniform(0, 256));
    if (rng.uniform(0, 2) == 0) {
      cv::rectangle(image, cv::Rect(corner.x, corner.y, w, h), grey, cv::FILLED);
    } else {
      cv::circle(image, corner, w / 2, grey, cv::FILLED);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 1.0);
  return image;
}

// Scales the contrast of `image` around 128 by gain(x, y) = gain inside
// `strong` and weak_gain elsewhere.
inline cv::Mat with_contrast(const cv::Mat& image, const cv::Rect& strong, double weak_gain) {
  cv::Mat out(image.size(), CV_8UC1);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const double g = strong.contains(cv::Point(x, y)) ? 1.0 : weak_gain;
      out.at<std::uint8_t>(y, x) =
          cv::saturate_cast<std::uint8_t>(128.0 + g * (image.at<std::uint8_t>(y, x) - 128.0));
    }
  }
  return out;
}

// Right image of a rectified pair whose scene is fronto-parallel per row
// band: R(x, y) = L(x + d(y), y), d(y) = disparity of the band containing y.
inline cv::Mat render_right(const cv::Mat& left, const std::vector<int>& band_end_rows,
                            const std::vector<double>& band_disparity_px) {
  cv::Mat map_x(left.size(), CV_32FC1);
  cv::Mat map_y(left.size(), CV_32FC1);
  for (int y = 0; y < left.rows; ++y) {
    size_t band = 0;
    while (band + 1 < band_end_rows.size() && y >= band_end_rows[band]) ++band;
    for (int x = 0; x < left.cols; ++x) {
      map_x.at<float>(y, x) = float(x + band_disparity_px[band]);
      map_y.at<float>(y, x) = float(y);
    }
  }
  cv::Mat right;
  cv::remap(left, right, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
  return right;
}

// A rectified pair: a shape scene (make_shapes_scene) on the left and its
// right image of the given row bands' disparities (render_right).
struct StereoImages {
  cv::Mat left;
  cv::Mat right;
};
inline StereoImages shapes_stereo_pair(cv::Size size, std::uint64_t seed,
                                       const std::vector<int>& band_end_rows,
                                       const std::vector<double>& band_disparity_px) {
  StereoImages pair;
  pair.left = make_shapes_scene(size, seed);
  pair.right = render_right(pair.left, band_end_rows, band_disparity_px);
  return pair;
}

}  // namespace sitepose::testing
