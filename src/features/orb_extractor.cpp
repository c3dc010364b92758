#include "sitepose/features/orb_extractor.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

#include <fmt/format.h>

#include "detail/distribution.hpp"

namespace sitepose::features {
namespace {

template <typename T>
Status invalid(const char* key, T value, const std::string& rule) {
  return make_error(ErrorCode::kInvalidArgument, fmt::format("orb.{} = {}: {}", key, value, rule));
}

// Row half-widths of the orientation disc: |u| <= kDiscHalfWidth[|v|].
const std::array<int, kOrientationRadiusPx + 1>& disc_half_widths() {
  static const std::array<int, kOrientationRadiusPx + 1> widths = [] {
    std::array<int, kOrientationRadiusPx + 1> w{};
    const double r2 = double(kOrientationRadiusPx) * kOrientationRadiusPx;
    for (int v = 0; v <= kOrientationRadiusPx; ++v) {
      w[v] = static_cast<int>(std::floor(std::sqrt(r2 - double(v) * v) + 1e-9));
    }
    return w;
  }();
  return widths;
}

// Budget per level falls geometrically with the level's area ratio so that
// features per unit of image area stay constant (as in ORB-SLAM2).
std::vector<int> level_budgets(int n_features, double scale_factor, int n_levels) {
  std::vector<int> budgets(n_levels);
  const double f = 1.0 / scale_factor;
  double per_level = n_features * (1.0 - f) / (1.0 - std::pow(f, n_levels));
  int assigned = 0;
  for (int l = 0; l < n_levels - 1; ++l) {
    budgets[l] = static_cast<int>(std::lround(per_level));
    assigned += budgets[l];
    per_level *= f;
  }
  budgets[n_levels - 1] = std::max(n_features - assigned, 0);
  return budgets;
}

}  // namespace

Status validate(const config::OrbConfig& c) {
  if (c.n_features < 1 || c.n_features > kMaxFeatures) {
    return invalid("n_features", c.n_features, fmt::format("must be in [1, {}]", kMaxFeatures));
  }
  if (!(c.scale_factor > 1.0 && c.scale_factor <= 2.0)) {
    return invalid("scale_factor", c.scale_factor, "must be in (1, 2]");
  }
  if (c.n_levels < 1 || c.n_levels > 16) {
    return invalid("n_levels", c.n_levels, "must be in [1, 16]");
  }
  if (c.strong_fast_threshold < 0 || c.strong_fast_threshold > 254) {
    return invalid("strong_fast_threshold", c.strong_fast_threshold, "must be in [0, 254]");
  }
  if (c.ini_fast_threshold < 1 || c.ini_fast_threshold > 254) {
    return invalid("ini_fast_threshold", c.ini_fast_threshold, "must be in [1, 254]");
  }
  if (c.min_fast_threshold < 1 || c.min_fast_threshold > c.ini_fast_threshold) {
    return invalid("min_fast_threshold", c.min_fast_threshold,
                   "must be in [1, ini_fast_threshold = " + std::to_string(c.ini_fast_threshold) + "]");
  }
  if (c.grid_cell_px < 8 || c.grid_cell_px > 1000) {
    return invalid("grid_cell_px", c.grid_cell_px, "must be in [8, 1000]");
  }
  return ok_status();
}

OrbExtractor::OrbExtractor(const config::OrbConfig& config, TaskPool* pool) : config_(config), pool_(pool) {
  SITEPOSE_CHECK(validate(config).has_value());
  const int n = config.n_levels;
  scale_factors_.resize(n);
  inv_scale_factors_.resize(n);
  level_sigma2_.resize(n);
  inv_level_sigma2_.resize(n);
  for (int l = 0; l < n; ++l) {
    scale_factors_[l] = std::pow(config.scale_factor, l);
    inv_scale_factors_[l] = 1.0 / scale_factors_[l];
    level_sigma2_[l] = scale_factors_[l] * scale_factors_[l];
    inv_level_sigma2_[l] = 1.0 / level_sigma2_[l];
  }
  features_per_level_ = level_budgets(config.n_features, config.scale_factor, n);
  if (config.strong_fast_threshold > config.ini_fast_threshold) {
    fast_thresholds_.push_back(config.strong_fast_threshold);
  }
  fast_thresholds_.push_back(config.ini_fast_threshold);
  if (config.min_fast_threshold < config.ini_fast_threshold)
    fast_thresholds_.push_back(config.min_fast_threshold);

  // One level per compute() call: the keypoints are given in that level's
  // pixels, so OpenCV blurs exactly our level image (7x7, sigma 2) and uses
  // our angle; its border filter is kEdgeMarginPx, which our keypoints meet.
  // One instance per level, so the levels can be described concurrently.
  descriptors_.resize(n);
  for (auto& descriptor : descriptors_) {
    descriptor = cv::ORB::create(config.n_features, static_cast<float>(config.scale_factor), 1, kEdgeMarginPx,
                                 0, 2, cv::ORB::HARRIS_SCORE, kPatchSizePx, config.ini_fast_threshold);
  }
}

Expected<OrbExtractor> OrbExtractor::create(const config::OrbConfig& config, TaskPool* pool) {
  SITEPOSE_TRY_STATUS(validate(config));
  return OrbExtractor(config, pool);
}

ImagePyramid OrbExtractor::make_pyramid(const cv::Mat& image, std::vector<cv::Mat> levels) const {
  ImagePyramid pyramid;
  const int n = config_.n_levels;
  pyramid.levels = std::move(levels);
  pyramid.levels.resize(n);
  pyramid.ratio_x.resize(n);
  pyramid.ratio_y.resize(n);
  pyramid.levels[0] = image;
  pyramid.ratio_x[0] = 1.0;
  pyramid.ratio_y[0] = 1.0;
  for (int l = 1; l < n; ++l) {
    const cv::Size size(std::max(1, static_cast<int>(std::lround(image.cols * inv_scale_factors_[l]))),
                        std::max(1, static_cast<int>(std::lround(image.rows * inv_scale_factors_[l]))));
    cv::resize(pyramid.levels[l - 1], pyramid.levels[l], size, 0, 0, cv::INTER_LINEAR);
    pyramid.ratio_x[l] = double(image.cols) / size.width;
    pyramid.ratio_y[l] = double(image.rows) / size.height;
  }
  return pyramid;
}

namespace {

// extract()'s preconditions, as errors that say what was given.
Status check_extract_inputs(const cv::Mat& image, const cv::Mat& mask) {
  constexpr int kMinSide = 2 * (kEdgeMarginPx + 1);
  if (image.empty() || image.type() != CV_8UC1) {
    return make_error(ErrorCode::kInvalidArgument,
                      "ORB extraction: image must be a non-empty CV_8UC1 image, got type " +
                          std::to_string(image.type()) + " size " + std::to_string(image.cols) + "x" +
                          std::to_string(image.rows));
  }
  if (image.cols < kMinSide || image.rows < kMinSide) {
    return make_error(ErrorCode::kInvalidArgument, "ORB extraction: image " + std::to_string(image.cols) +
                                                       "x" + std::to_string(image.rows) +
                                                       " is smaller than " + std::to_string(kMinSide) + "x" +
                                                       std::to_string(kMinSide));
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != image.size())) {
    return make_error(ErrorCode::kInvalidArgument,
                      "ORB extraction: mask must be empty or CV_8UC1 of the image size " +
                          std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", got type " +
                          std::to_string(mask.type()) + " size " + std::to_string(mask.cols) + "x" +
                          std::to_string(mask.rows));
  }
  return ok_status();
}

// The area of a level where keypoints may lie (empty when the level is too
// small).
cv::Rect keypoint_area(const cv::Mat& level_image) {
  return {kEdgeMarginPx, kEdgeMarginPx, level_image.cols - 2 * kEdgeMarginPx,
          level_image.rows - 2 * kEdgeMarginPx};
}

}  // namespace

void OrbExtractor::for_each_level(const std::function<void(int)>& job) const {
  if (pool_ != nullptr) {
    pool_->run(config_.n_levels, job);
  } else {
    for (int level = 0; level < config_.n_levels; ++level) job(level);
  }
}

std::vector<std::vector<cv::KeyPoint>> OrbExtractor::detect_candidates(const OrbExtraction& x,
                                                                       int level) const {
  const ImagePyramid& pyramid = x.pyramid_;
  const cv::Mat& mask = x.mask_;
  const cv::Mat& mask_integral = x.mask_integral_;
  const int n_sides = static_cast<int>(x.budgets_.size());
  const cv::Mat& img = pyramid.levels[level];
  const cv::Rect area = keypoint_area(img);
  if (area.width <= 0 || area.height <= 0) return std::vector<std::vector<cv::KeyPoint>>(n_sides);
  // Masked candidates go before cells are judged and before the
  // distribution, so the budget moves to unmasked areas (side 0); with two
  // sides they are the masked area's (side 1).
  detail::CandidateSides sides;
  sides.n_sides = n_sides;
  sides.side_of = [&](float x, float y) {
    if (mask.empty()) return 0;
    const cv::Point2d p0 = pyramid.to_level0(level, cv::Point2d(x, y));
    // Test exactly the pixel the returned float keypoint rounds to.
    const int u = std::clamp(static_cast<int>(std::lround(float(p0.x))), 0, mask.cols - 1);
    const int v = std::clamp(static_cast<int>(std::lround(float(p0.y))), 0, mask.rows - 1);
    if (mask.at<std::uint8_t>(v, u) == 0) return 0;
    return n_sides > 1 ? 1 : -1;
  };
  sides.may_hold = [&](const cv::Rect& cell, int side) {
    if (mask.empty()) return side == 0;
    // The level-0 pixels the cell's pixels round to, plus one pixel each way.
    const cv::Point2d first = pyramid.to_level0(level, cv::Point2d(cell.x, cell.y));
    const cv::Point2d last = pyramid.to_level0(level, cv::Point2d(cell.br().x - 1, cell.br().y - 1));
    const int u0 = std::clamp(static_cast<int>(std::floor(first.x)) - 1, 0, mask.cols - 1);
    const int v0 = std::clamp(static_cast<int>(std::floor(first.y)) - 1, 0, mask.rows - 1);
    const int u1 = std::clamp(static_cast<int>(std::ceil(last.x)) + 1, 0, mask.cols - 1);
    const int v1 = std::clamp(static_cast<int>(std::ceil(last.y)) + 1, 0, mask.rows - 1);
    const int masked = mask_integral.at<int>(v1 + 1, u1 + 1) - mask_integral.at<int>(v0, u1 + 1) -
                       mask_integral.at<int>(v1 + 1, u0) + mask_integral.at<int>(v0, u0);
    return side == 0 ? masked < (u1 - u0 + 1) * (v1 - v0 + 1) : masked > 0;
  };
  return detail::detect_fast_per_cell(img, area, config_.grid_cell_px, fast_thresholds_, sides);
}

void OrbExtractor::describe(const ImagePyramid& pyramid, int level, std::vector<cv::KeyPoint>& kps,
                            cv::Mat& descriptors) const {
  const cv::Mat& img = pyramid.levels[level];
  for (cv::KeyPoint& kp : kps) {
    kp.angle = static_cast<float>(
        intensity_centroid_angle_deg(img, static_cast<int>(kp.pt.x), static_cast<int>(kp.pt.y)));
    kp.octave = 0;  // level-local for compute(); set to `level` below
    kp.size = float(kPatchSizePx);
    kp.class_id = -1;
  }
  const size_t n_before = kps.size();
  descriptors_[level]->compute(img, kps, descriptors);
  // Our keypoints satisfy OpenCV's border filter, so none may be dropped
  // and rows stay aligned with keypoints.
  SITEPOSE_CHECK(kps.size() == n_before && descriptors.rows == static_cast<int>(n_before));
  for (cv::KeyPoint& kp : kps) {
    const cv::Point2d p0 = pyramid.to_level0(level, cv::Point2d(kp.pt.x, kp.pt.y));
    kp.pt = cv::Point2f(float(p0.x), float(p0.y));
    kp.octave = level;
    kp.size = float(kPatchSizePx * scale_factors_[level]);
  }
}

Expected<OrbFeatures> OrbExtractor::extract(const cv::Mat& image, const cv::Mat& mask) {
  SITEPOSE_TRY(std::vector<OrbFeatures> sides, extract_sides(image, mask, 0));
  return std::move(sides[0]);
}

Expected<MaskSideFeatures> OrbExtractor::extract_both_sides(const cv::Mat& image, const cv::Mat& mask,
                                                            int inside_features) {
  if (inside_features < 1) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("ORB extraction: inside_features = {}: must be >= 1", inside_features));
  }
  SITEPOSE_TRY(std::vector<OrbFeatures> sides, extract_sides(image, mask, inside_features));
  MaskSideFeatures out;
  out.outside = std::move(sides[0]);
  out.inside = std::move(sides[1]);
  return out;
}

Expected<std::vector<OrbFeatures>> OrbExtractor::extract_sides(const cv::Mat& image, const cv::Mat& mask,
                                                               int inside_features) {
  SITEPOSE_TRY(OrbExtraction x, begin(image, mask, inside_features));
  build_pyramid(x);
  for_each_level([&](int level) { detect_level(x, level); });
  select(x);
  for_each_level([&](int level) { describe_level(x, level); });
  return finish(std::move(x));
}

Expected<OrbExtraction> OrbExtractor::begin(const cv::Mat& image, const cv::Mat& mask, int inside_features,
                                            std::vector<CornerHint> hints) const {
  SITEPOSE_TRY_STATUS(check_extract_inputs(image, cv::Mat()));
  OrbExtraction x;
  x.image_ = image;
  x.hints_ = std::move(hints);
  x.budgets_.push_back(features_per_level_);
  const int n_levels = config_.n_levels;
  x.candidates_.resize(n_levels);
  x.picked_.assign(n_levels, OrbExtraction::Sides(x.budgets_.size()));
  x.described_.resize(n_levels);
  x.descriptors_.resize(n_levels);
  SITEPOSE_TRY_STATUS(set_mask(x, mask, inside_features));
  return x;
}

Status OrbExtractor::set_mask(OrbExtraction& x, const cv::Mat& mask, int inside_features) const {
  SITEPOSE_TRY_STATUS(check_extract_inputs(x.image_, mask));
  if (inside_features < 0 || inside_features > kMaxFeatures) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("ORB extraction: inside_features = {}: must be in [0, {}]", inside_features,
                                  kMaxFeatures));
  }
  x.mask_ = mask;
  x.budgets_.resize(1);
  if (inside_features > 0) {
    x.budgets_.push_back(level_budgets(inside_features, config_.scale_factor, config_.n_levels));
  }
  x.picked_.assign(static_cast<std::size_t>(config_.n_levels), OrbExtraction::Sides(x.budgets_.size()));
  if (mask.empty()) return ok_status();
  // Masked pixel counts over rectangles, to skip the fallback FAST in cells
  // that hold no pixel of a side.
  {
    std::lock_guard lock(recycled_->mutex);
    x.mask_binary_ = std::move(recycled_->mask_binary);
    x.mask_integral_ = std::move(recycled_->mask_integral);
  }
  cv::threshold(x.mask_, x.mask_binary_, 0, 1, cv::THRESH_BINARY);
  cv::integral(x.mask_binary_, x.mask_integral_, CV_32S);
  return ok_status();
}

void OrbExtractor::build_pyramid(OrbExtraction& x) const {
  std::vector<cv::Mat> levels;
  {
    std::lock_guard lock(recycled_->mutex);
    levels = std::move(recycled_->pyramid_levels);
  }
  x.pyramid_ = make_pyramid(x.image_, std::move(levels));
}

void OrbExtractor::detect_level(OrbExtraction& x, int level) const {
  x.candidates_[level] = detect_candidates(x, level);
}

void OrbExtractor::select(OrbExtraction& x) const {
  // The hints in each level's pixels, in the caller's order (both sides
  // look at the same ones).
  std::vector<std::vector<cv::Point2f>> hints_of_level(static_cast<std::size_t>(config_.n_levels));
  for (const CornerHint& hint : x.hints_) {
    if (hint.octave < 0 || hint.octave >= config_.n_levels) continue;
    const cv::Point2d p = x.pyramid_.from_level0(hint.octave, cv::Point2d(hint.uv_px.x, hint.uv_px.y));
    hints_of_level[static_cast<std::size_t>(hint.octave)].emplace_back(float(p.x), float(p.y));
  }
  // The budget depends on the levels below (unused budget of a texture-poor
  // or masked level moves to the next level): in level order, each side on
  // its own.
  for (std::size_t side = 0; side < x.budgets_.size(); ++side) {
    int carried_budget = 0;
    for (int level = 0; level < config_.n_levels; ++level) {
      const int budget = x.budgets_[side][level] + carried_budget;
      carried_budget = budget;
      if (budget <= 0) continue;
      const cv::Rect area = keypoint_area(x.pyramid_.levels[level]);
      const std::vector<cv::KeyPoint>& candidates = x.candidates_[level][side];
      const std::vector<int> picked = detail::keep_hinted_then_distribute(
          candidates, cv::Rect2f(float(area.x), float(area.y), float(area.width), float(area.height)), budget,
          hints_of_level[static_cast<std::size_t>(level)]);
      if (picked.empty()) continue;
      carried_budget = budget - static_cast<int>(picked.size());
      std::vector<cv::KeyPoint>& kept = x.picked_[level][side];
      kept.reserve(picked.size());
      for (const int i : picked) kept.push_back(candidates[i]);
    }
  }
}

void OrbExtractor::describe_level(OrbExtraction& x, int level) const {
  // One descriptor call for all sides (a descriptor depends only on its own
  // keypoint, and the level is blurred once); rows in side order.
  std::vector<cv::KeyPoint>& keypoints = x.described_[level];
  for (const auto& side : x.picked_[level]) keypoints.insert(keypoints.end(), side.begin(), side.end());
  if (!keypoints.empty()) describe(x.pyramid_, level, keypoints, x.descriptors_[level]);
}

std::vector<OrbFeatures> OrbExtractor::finish(OrbExtraction&& x) const {
  const int n_sides = static_cast<int>(x.budgets_.size());
  std::vector<OrbFeatures> out(n_sides);
  for (int side = 0; side < n_sides; ++side) {
    std::vector<cv::Mat> level_descriptors;
    for (int level = 0; level < config_.n_levels; ++level) {
      int first_row = 0;
      for (int s = 0; s < side; ++s) first_row += static_cast<int>(x.picked_[level][s].size());
      const int n = static_cast<int>(x.picked_[level][side].size());
      if (n == 0) continue;
      const auto first = x.described_[level].begin() + first_row;
      out[side].keypoints.insert(out[side].keypoints.end(), first, first + n);
      level_descriptors.push_back(x.descriptors_[level].rowRange(first_row, first_row + n));
    }
    if (!level_descriptors.empty()) cv::vconcat(level_descriptors, out[side].descriptors);
  }
  out[0].pyramid = std::move(x.pyramid_);
  if (!x.mask_integral_.empty()) {
    std::lock_guard lock(recycled_->mutex);
    recycled_->mask_binary = std::move(x.mask_binary_);
    recycled_->mask_integral = std::move(x.mask_integral_);
  }
  return out;
}

namespace {

// No other cv::Mat shares `mat`'s buffer. The reference count is OpenCV's
// (changed atomically by every copy and release); an acquire load pairs
// with the release of the last other holder, whose reads then precede any
// write into the buffer.
bool sole_owner(const cv::Mat& mat) {
  return mat.u != nullptr && std::atomic_ref<int>(mat.u->refcount).load(std::memory_order_acquire) == 1;
}

}  // namespace

void OrbExtractor::recycle(ImagePyramid&& pyramid) const {
  std::vector<cv::Mat> levels = std::move(pyramid.levels);
  if (levels.empty()) return;
  levels[0].release();  // the caller's image
  for (cv::Mat& level : levels) {
    if (!level.empty() && !sole_owner(level)) level.release();
  }
  std::lock_guard lock(recycled_->mutex);
  recycled_->pyramid_levels = std::move(levels);
}

double intensity_centroid_angle_deg(const cv::Mat& image, int x, int y) {
  SITEPOSE_CHECK(x >= kOrientationRadiusPx && y >= kOrientationRadiusPx &&
                 x < image.cols - kOrientationRadiusPx && y < image.rows - kOrientationRadiusPx);
  const auto& half_width = disc_half_widths();
  const std::uint8_t* center = image.ptr<std::uint8_t>(y) + x;
  const auto step = static_cast<std::ptrdiff_t>(image.step1());
  int m10 = 0;
  int m01 = 0;
  for (int u = -kOrientationRadiusPx; u <= kOrientationRadiusPx; ++u) m10 += u * center[u];
  // Rows +v and -v together: their x-moments add, their y-moments subtract.
  for (int v = 1; v <= kOrientationRadiusPx; ++v) {
    int row_difference = 0;
    const int d = half_width[v];
    for (int u = -d; u <= d; ++u) {
      const int below = center[u + v * step];
      const int above = center[u - v * step];
      row_difference += below - above;
      m10 += u * (below + above);
    }
    m01 += v * row_difference;
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
}

}  // namespace sitepose::features
