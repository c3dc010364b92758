#pragma once
// One call per stereo pair: masked ORB on the left image and ORB on the
// right image, extracted concurrently, then stereo matching. The one
// extraction path of the tracker and the tools.
//
// Only the left image is masked (METHOD.md "What the authors' public code
// does"): the tracker uses left keypoints; right ones only serve as match
// candidates. The mask keeps the left budget away from its pixels; with
// masked_area_features > 0 the masked area gets that many features of its
// own (so a later pass can unmask objects), appended after the others; both
// come from one pyramid and one FAST pass (OrbExtractor::extract_both_sides).
// Threads: the two images' extraction steps (OrbExtractor::begin) run as
// shared batches on the lent TaskPool: both pyramids (beside them, on the
// caller's thread, the left mask when a maker is given), then every level's
// FAST of both images, both selections, every level's descriptors (no
// pool: all on the caller's thread, same result); one extract() at a time
// per instance. Ownership: the result owns its data and shares nothing with
// the caller's images; the pyramids go back to the extractors for the next
// pair (OrbExtractor::recycle).

#include <array>
#include <functional>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/features/orb_extractor.hpp"
#include "sitepose/features/stereo_matcher.hpp"
#include "sitepose/features/task_pool.hpp"

namespace sitepose::features {

// Wall time of the steps of one extract().
struct StereoTimings {
  // Work on each image (with the left masked area's share): the time of
  // its steps summed over the threads that ran them, so not wall time.
  double extract_left_ms = 0.0;
  double extract_right_ms = 0.0;
  double stereo_match_ms = 0.0;
  // Wall time the frame waited on the mask maker beyond the pyramids it ran
  // beside: max(0, maker + its pyramid wait - the longer pyramid job).
  double mask_overrun_ms = 0.0;
};

// Features of one stereo pair, indexed by left keypoint.
struct StereoFeatures {
  std::vector<cv::KeyPoint> keypoints;         // left, level-0 pixels (see OrbExtractor)
  cv::Mat descriptors;                         // N x 32 CV_8UC1, row i = keypoints[i]
  std::vector<double> u_right;                 // right column of the match, kNoMatch (< 0) if none
  std::vector<double> depth_m;                 // bf / disparity, kNoMatch (< 0) if none
  std::vector<std::uint8_t> stereo_ambiguous;  // 1 = repeated texture (StereoMatches::ambiguous)
  // Right-image features (unmasked), for matchers that need both images.
  std::vector<cv::KeyPoint> right_keypoints;
  cv::Mat right_descriptors;
  StereoMatchStats stats;
  StereoTimings timings;

  int size() const { return static_cast<int>(keypoints.size()); }
  bool has_depth(int i) const { return depth_m[i] > 0.0; }
};

struct StereoExtractorOptions {
  // Worker threads for the images and their levels; must outlive the
  // extractor. nullptr: everything on the caller's thread (same result).
  TaskPool* pool = nullptr;
  // Feature budget of the left mask's area (0: no keypoints there).
  int masked_area_features = 0;
};

class StereoExtractor {
 public:
  // Preconditions: both configs validated, camera.bf() > 0 and
  // options.masked_area_features in [0, 100000] (aborts otherwise);
  // create() checks and returns the error instead.
  StereoExtractor(const config::OrbConfig& orb, const config::StereoMatchConfig& stereo,
                  const StereoCamera& camera, const StereoExtractorOptions& options = {});
  static Expected<StereoExtractor> create(const config::OrbConfig& orb,
                                          const config::StereoMatchConfig& stereo, const StereoCamera& camera,
                                          const StereoExtractorOptions& options = {});

  // left/right: rectified CV_8UC1 images of equal size; left_mask: empty or
  // CV_8UC1 of the image size, nonzero = masked (applied to the left only;
  // an all-zero mask is the same as none).
  // left_hints: corners of the left image to keep (CornerHint).
  Expected<StereoFeatures> extract(const cv::Mat& left, const cv::Mat& right,
                                   const cv::Mat& left_mask = cv::Mat(),
                                   std::vector<CornerHint> left_hints = {});
  Expected<StereoFeatures> extract(const StereoFrame& frame, const cv::Mat& left_mask = cv::Mat(),
                                   std::vector<CornerHint> left_hints = {}) {
    return extract(frame.left, frame.right, left_mask, std::move(left_hints));
  }
  // The same with the left mask made by make_left_mask, on the calling
  // thread while the pool builds the two pyramids (a detector's
  // segmentation overlaps them); its error is returned.
  using LeftMaskMaker = std::function<Expected<cv::Mat>()>;
  Expected<StereoFeatures> extract(const cv::Mat& left, const cv::Mat& right,
                                   const LeftMaskMaker& make_left_mask,
                                   std::vector<CornerHint> left_hints = {});

  // Per-level scale tables (identical for both images).
  const OrbExtractor& orb() const { return left_; }
  const StereoMatcher& matcher() const { return matcher_; }

 private:
  // Both pyramids on the pool while make_left_mask runs on this thread and
  // its mask is set on the left extraction; adds each image's work to
  // work_ms. Returns the maker's error or the mask's.
  Status pyramids_beside_mask(OrbExtraction& left_extraction, OrbExtraction& right_extraction,
                              const LeftMaskMaker& make_left_mask, std::array<double, 2>& work_ms,
                              double& mask_overrun_ms);

  OrbExtractor left_;
  OrbExtractor right_;
  int masked_area_features_;  // 0: no keypoints on the mask
  StereoMatcher matcher_;
  TaskPool* pool_;
};

}  // namespace sitepose::features
