#pragma once
// Masked ORB extraction on an image pyramid (METHOD.md "Core tracker";
// masking per METHOD.md "What the authors' public code does").
//
// Pipeline per pyramid level: FAST at the initial threshold, and at the
// minimum threshold in grid cells left without candidates (the ini -> min
// fallback); candidates whose level-0 pixel is masked are dropped before
// that judgement -> the candidates nearest the caller's hints, if any
// (CornerHint) -> quadtree selection of the rest of the level's budget,
// strongest candidate per node -> orientation by intensity centroid ->
// steered BRIEF (OpenCV's ORB descriptor on the Gaussian-blurred level).
// With extract_both_sides the masked area is a second side with a budget of
// its own, judged on its own candidates from the same FAST pass.
//
// Coordinates: keypoints are returned in level-0 pixels (x right, y down,
// pixel centres at integers), with octave = pyramid level, angle in degrees
// [0, 360) in image axes, response = FAST score, size = 31 * level scale.
// Threads: with a TaskPool, the levels' FAST and their descriptors run as
// one job per level on the pool (the result does not depend on it; the
// budget carried from level to level is settled in order in between); a
// caller can also run the steps itself (begin ... finish). One extraction
// at a time per instance (it owns OpenCV state); separate instances are
// independent (StereoExtractor runs two at once).

#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/features/task_pool.hpp"

namespace sitepose::features {

// Keypoints stay this far (level pixels) from every level border: the
// orientation patch has radius 15 and the descriptor window is padded by
// OpenCV beyond that.
inline constexpr int kEdgeMarginPx = 16;
// Intensity-centroid patch radius (ORB paper: patch size 31).
inline constexpr int kOrientationRadiusPx = 15;
inline constexpr int kPatchSizePx = 2 * kOrientationRadiusPx + 1;
// The most features one extraction (or the masked area's share) may ask for.
inline constexpr int kMaxFeatures = 100000;

// The levels of one image. Level 0 shares the input image's pixels.
struct ImagePyramid {
  std::vector<cv::Mat> levels;  // CV_8UC1
  // Exact size ratios level 0 / level l (round-off makes them differ
  // slightly from the nominal scale factor).
  std::vector<double> ratio_x;
  std::vector<double> ratio_y;

  int n_levels() const { return static_cast<int>(levels.size()); }
  // Level-l pixel -> level-0 pixel, in cv::resize's pixel-centre convention.
  cv::Point2d to_level0(int level, const cv::Point2d& p_level) const {
    return {(p_level.x + 0.5) * ratio_x[level] - 0.5, (p_level.y + 0.5) * ratio_y[level] - 0.5};
  }
  cv::Point2d from_level0(int level, const cv::Point2d& p0) const {
    return {(p0.x + 0.5) / ratio_x[level] - 0.5, (p0.y + 0.5) / ratio_y[level] - 0.5};
  }
};

// Result of one extraction. descriptors row i belongs to keypoints[i].
struct OrbFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;   // N x 32, CV_8UC1 (empty when N == 0)
  ImagePyramid pyramid;  // the unblurred levels the keypoints were found on
};

// Both sides of a mask from one extraction (OrbExtractor::extract_both_sides).
struct MaskSideFeatures {
  OrbFeatures outside;  // exactly what extract(image, mask) returns; holds the pyramid
  OrbFeatures inside;   // the masked area with its own budget; its pyramid is left empty
};

// Where a corner the tracker matched in the last frame should be now (its
// map point projected with the predicted pose): the extractor keeps the
// strongest candidate near it before spreading the rest of the budget, so
// tracked corners are found again instead of a neighbour the spread picked.
struct CornerHint {
  cv::Point2f uv_px;  // level-0 pixels
  int octave = 0;     // the level it was matched at
};

// One extraction in progress, for OrbExtractor's steps (see
// OrbExtractor::begin). Only the extractor that began it reads or writes it.
class OrbExtraction {
 private:
  friend class OrbExtractor;
  cv::Mat image_;
  cv::Mat mask_;
  cv::Mat mask_binary_;    // 1 = masked (scratch for mask_integral_)
  cv::Mat mask_integral_;  // masked-pixel counts (empty without a mask)
  std::vector<CornerHint> hints_;
  std::vector<std::vector<int>> budgets_;  // [side][level]
  ImagePyramid pyramid_;
  using Sides = std::vector<std::vector<cv::KeyPoint>>;
  std::vector<Sides> candidates_;                     // [level][side], level pixels
  std::vector<Sides> picked_;                         // [level][side], level pixels
  std::vector<std::vector<cv::KeyPoint>> described_;  // [level], sides in order, level-0 pixels
  std::vector<cv::Mat> descriptors_;                  // [level], rows = described_[level]
};

// Checks every OrbConfig field; the message names the key, value and rule.
Status validate(const config::OrbConfig& config);

class OrbExtractor {
 public:
  // Precondition: validate(config) passed (load_config does it); aborts
  // otherwise. Use create() for configs that did not go through load_config.
  // pool: lent worker threads for the levels (must outlive the extractor);
  // nullptr = all on the caller's thread.
  explicit OrbExtractor(const config::OrbConfig& config, TaskPool* pool = nullptr);
  static Expected<OrbExtractor> create(const config::OrbConfig& config, TaskPool* pool = nullptr);

  // image: CV_8UC1, at least 2 * (kEdgeMarginPx + 1) pixels each way.
  // mask: empty, or CV_8UC1 of the image's size, nonzero = masked. No
  // keypoint whose level-0 pixel (lround(x), lround(y)) is masked is
  // returned, and masked candidates are removed before the distribution so
  // the budget goes to unmasked areas.
  Expected<OrbFeatures> extract(const cv::Mat& image, const cv::Mat& mask = cv::Mat());
  // Both sides of `mask` (same rules as extract) from one pyramid and one
  // FAST pass per level: `outside` is extract(image, mask); `inside` is
  // what an extractor with n_features = inside_features returns for
  // extract(image, mask == 0), i.e. the masked area with a budget of its own,
  // bit for bit. inside_features >= 1.
  Expected<MaskSideFeatures> extract_both_sides(const cv::Mat& image, const cv::Mat& mask,
                                                int inside_features);

  // The steps extract() and extract_both_sides() run, for a caller that
  // puts the steps of several images into one batch of jobs (as
  // StereoExtractor does with the two images of a pair):
  //   begin -> build_pyramid -> detect_level(l) for every level (any order,
  //   any thread) -> select (in level order) -> describe_level(l) for every
  //   level -> finish.
  // The same inputs give the same result, however the steps are spread.
  // begin checks the inputs; inside_features = 0 extracts the unmasked
  // area only (extract), >= 1 both sides (extract_both_sides).
  // hints: corners to keep (CornerHint), at most half of a level's budget.
  Expected<OrbExtraction> begin(const cv::Mat& image, const cv::Mat& mask, int inside_features = 0,
                                std::vector<CornerHint> hints = {}) const;
  // Replaces the mask and the masked area's budget that begin() set (same
  // checks and meaning), up to the start of detect_level: a caller can begin
  // without the mask, build the pyramid while the mask is being made, and
  // set it then (build_pyramid does not read it).
  Status set_mask(OrbExtraction& x, const cv::Mat& mask, int inside_features) const;
  void build_pyramid(OrbExtraction& x) const;
  void detect_level(OrbExtraction& x, int level) const;
  void select(OrbExtraction& x) const;
  void describe_level(OrbExtraction& x, int level) const;
  // The unmasked area's features (with the pyramid), then the masked
  // area's when begun with inside_features >= 1.
  std::vector<OrbFeatures> finish(OrbExtraction&& x) const;
  // Hands a pyramid this extractor made back once the caller is done with
  // it, so that the next extraction resizes into memory already touched.
  // Levels that another cv::Mat still shares are dropped, never reused.
  void recycle(ImagePyramid&& pyramid) const;

  const config::OrbConfig& config() const { return config_; }
  int n_levels() const { return config_.n_levels; }
  // Nominal per-level factors: scale = scale_factor^level, sigma2 = scale^2
  // (keypoint position variance in level-0 pixels², for information matrices).
  const std::vector<double>& scale_factors() const { return scale_factors_; }
  const std::vector<double>& inv_scale_factors() const { return inv_scale_factors_; }
  const std::vector<double>& level_sigma2() const { return level_sigma2_; }
  const std::vector<double>& inv_level_sigma2() const { return inv_level_sigma2_; }
  // Feature budget of each level before unused budget is carried upwards.
  const std::vector<int>& features_per_level() const { return features_per_level_; }

 private:
  // levels: buffers to resize into (a recycled pyramid's), may be empty.
  ImagePyramid make_pyramid(const cv::Mat& image, std::vector<cv::Mat> levels = {}) const;
  // job(level) for every level, on the pool when there is one.
  void for_each_level(const std::function<void(int)>& job) const;
  // All steps, the levels on the pool.
  Expected<std::vector<OrbFeatures>> extract_sides(const cv::Mat& image, const cv::Mat& mask,
                                                   int inside_features);
  // FAST candidates of one level (level pixels) per side of the mask.
  std::vector<std::vector<cv::KeyPoint>> detect_candidates(const OrbExtraction& x, int level) const;
  // Orientation and descriptors of the level's picked keypoints (level
  // pixels in, level-0 pixels out).
  void describe(const ImagePyramid& pyramid, int level, std::vector<cv::KeyPoint>& kps,
                cv::Mat& descriptors) const;

  config::OrbConfig config_;
  std::vector<double> scale_factors_;
  std::vector<double> inv_scale_factors_;
  std::vector<double> level_sigma2_;
  std::vector<double> inv_level_sigma2_;
  std::vector<int> features_per_level_;
  std::vector<int> fast_thresholds_;           // the per-cell ladder, descending (config)
  std::vector<cv::Ptr<cv::ORB>> descriptors_;  // per level; used only for rBRIEF compute()
  TaskPool* pool_;
  // The mask's binary image and integral (2.6 MB at 960x540) and the
  // pyramid's levels 1.. (1.1 MB), handed from one extraction's finish()
  // (the pyramid: from recycle()) to the next one's set_mask() (the
  // pyramid: build_pyramid()), so
  // that a frame writes into memory the process already touched: a fresh
  // allocation of that size cost 1-9 ms of page faults in some frames on
  // the 2-core machine (0.1 ms reused). Extractions running at once on one
  // extractor each take the buffers or allocate their own; copies of the
  // extractor share the slot. mutex guards the Mats.
  struct RecycledBuffers {
    std::mutex mutex;
    cv::Mat mask_binary;
    cv::Mat mask_integral;
    std::vector<cv::Mat> pyramid_levels;  // [0] unused (the caller's image)
  };
  std::shared_ptr<RecycledBuffers> recycled_ = std::make_shared<RecycledBuffers>();
};

// Orientation of the patch around (x, y) by the intensity centroid over a
// disc of radius kOrientationRadiusPx: atan2(m01, m10) in degrees [0, 360),
// image axes (y down). (x, y) must be >= kOrientationRadiusPx from borders.
double intensity_centroid_angle_deg(const cv::Mat& image, int x, int y);

}  // namespace sitepose::features
