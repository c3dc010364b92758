#include "sitepose/features/stereo_extractor.hpp"

#include <algorithm>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <utility>

#include "sitepose/core/stopwatch.hpp"

namespace sitepose::features {
namespace {

// Appends b's keypoints and descriptor rows to a's.
void append(OrbFeatures& a, const OrbFeatures& b) {
  if (b.keypoints.empty()) return;
  a.keypoints.insert(a.keypoints.end(), b.keypoints.begin(), b.keypoints.end());
  if (a.descriptors.empty()) {
    a.descriptors = b.descriptors;
  } else {
    cv::vconcat(a.descriptors, b.descriptors, a.descriptors);
  }
}

}  // namespace

StereoExtractor::StereoExtractor(const config::OrbConfig& orb, const config::StereoMatchConfig& stereo,
                                 const StereoCamera& camera, const StereoExtractorOptions& options)
    : left_(orb, options.pool),
      right_(orb, options.pool),
      masked_area_features_(options.masked_area_features),
      matcher_(stereo, camera.bf()),
      pool_(options.pool) {
  SITEPOSE_CHECK(options.masked_area_features >= 0 && options.masked_area_features <= kMaxFeatures);
}

Expected<StereoExtractor> StereoExtractor::create(const config::OrbConfig& orb,
                                                  const config::StereoMatchConfig& stereo,
                                                  const StereoCamera& camera,
                                                  const StereoExtractorOptions& options) {
  SITEPOSE_TRY_STATUS(validate(orb));
  SITEPOSE_TRY_STATUS(StereoMatcher::create(stereo, camera.bf()));  // checks config and bf
  if (options.masked_area_features < 0 || options.masked_area_features > kMaxFeatures) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "stereo extraction: masked_area_features = " + std::to_string(options.masked_area_features) +
            ": must be in [0, " + std::to_string(kMaxFeatures) + "]");
  }
  return StereoExtractor(orb, stereo, camera, options);
}

Expected<StereoFeatures> StereoExtractor::extract(const cv::Mat& left, const cv::Mat& right,
                                                  const cv::Mat& left_mask,
                                                  std::vector<CornerHint> left_hints) {
  return extract(
      left, right, [&]() -> Expected<cv::Mat> { return left_mask; }, std::move(left_hints));
}

Status StereoExtractor::pyramids_beside_mask(OrbExtraction& left_extraction, OrbExtraction& right_extraction,
                                             const LeftMaskMaker& make_left_mask,
                                             std::array<double, 2>& work_ms, double& mask_overrun_ms) {
  // The mask is made on this thread while the pyramids are built (they do
  // not read it); its integral counts as the left image's work.
  Status mask_status = ok_status();
  const auto make_and_set_mask = [&] {
    Expected<cv::Mat> mask = make_left_mask();
    if (!mask) {
      mask_status = Unexpected{mask.error()};
      return;
    }
    const auto start = SteadyClock::now();
    const bool both_sides = masked_area_features_ > 0 && !mask->empty();
    mask_status = left_.set_mask(left_extraction, *mask, both_sides ? masked_area_features_ : 0);
    work_ms[0] += ms_since(start);
  };
  const std::array<const OrbExtractor*, 2> extractors{&left_, &right_};
  const std::array<OrbExtraction*, 2> extractions{&left_extraction, &right_extraction};
  std::array<double, 2> pyramid_ms{0.0, 0.0};
  const auto pyramid_job = [&](int j) {
    const auto start = SteadyClock::now();
    extractors[j]->build_pyramid(*extractions[j]);
    pyramid_ms[j] = ms_since(start);
  };
  const auto phase_start = SteadyClock::now();
  if (pool_ != nullptr) {
    pool_->run_beside(2, pyramid_job, make_and_set_mask);
  } else {
    make_and_set_mask();
    pyramid_job(0);
    pyramid_job(1);
  }
  mask_overrun_ms = std::max(0.0, ms_since(phase_start) - std::max(pyramid_ms[0], pyramid_ms[1]));
  work_ms[0] += pyramid_ms[0];
  work_ms[1] += pyramid_ms[1];
  return mask_status;
}

Expected<StereoFeatures> StereoExtractor::extract(const cv::Mat& left, const cv::Mat& right,
                                                  const LeftMaskMaker& make_left_mask,
                                                  std::vector<CornerHint> left_hints) {
  if (left.size() != right.size() || left.type() != right.type()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "stereo extraction: left " + std::to_string(left.cols) + "x" +
                          std::to_string(left.rows) + " type " + std::to_string(left.type()) + " and right " +
                          std::to_string(right.cols) + "x" + std::to_string(right.rows) + " type " +
                          std::to_string(right.type()) + " must have the same size and type");
  }
  SITEPOSE_TRY(OrbExtraction left_extraction, left_.begin(left, cv::Mat(), 0, std::move(left_hints)));
  SITEPOSE_TRY(OrbExtraction right_extraction, right_.begin(right, cv::Mat()));
  // The two images' steps go into shared batches (both pyramids, then all
  // levels' FAST of both, ...), so the threads stay busy until a step is
  // done for both; left_ and right_ share no state.
  const std::array<const OrbExtractor*, 2> extractors{&left_, &right_};
  const std::array<OrbExtraction*, 2> extractions{&left_extraction, &right_extraction};
  std::array<double, 2> work_ms{0.0, 0.0};
  // step(image, level) for both images and `per_image` levels, as jobs
  // level-major (the largest level first, the images interleaved); each
  // job's time counts for its image.
  const auto run_step = [&](int per_image, const auto& step) {
    std::vector<double> job_ms(2 * per_image, 0.0);
    const auto job = [&](int j) {
      const auto start = SteadyClock::now();
      step(*extractors[j % 2], *extractions[j % 2], j / 2);
      job_ms[j] = ms_since(start);
    };
    if (pool_ != nullptr) {
      pool_->run(2 * per_image, job);
    } else {
      for (int j = 0; j < 2 * per_image; ++j) job(j);
    }
    for (int j = 0; j < 2 * per_image; ++j) work_ms[j % 2] += job_ms[j];
  };
  double mask_overrun_ms = 0.0;
  SITEPOSE_TRY_STATUS(
      pyramids_beside_mask(left_extraction, right_extraction, make_left_mask, work_ms, mask_overrun_ms));
  const int n_levels = left_.n_levels();
  run_step(n_levels, [](const OrbExtractor& e, OrbExtraction& x, int level) { e.detect_level(x, level); });
  run_step(1, [](const OrbExtractor& e, OrbExtraction& x, int) { e.select(x); });
  run_step(n_levels, [](const OrbExtractor& e, OrbExtraction& x, int level) { e.describe_level(x, level); });
  std::vector<OrbFeatures> left_sides = left_.finish(std::move(left_extraction));
  std::vector<OrbFeatures> right_sides = right_.finish(std::move(right_extraction));
  if (left_sides.size() > 1) append(left_sides[0], left_sides[1]);
  OrbFeatures& left_ok = left_sides[0];
  OrbFeatures& right_ok = right_sides[0];
  StereoTimings timings;
  timings.extract_left_ms = work_ms[0];
  timings.extract_right_ms = work_ms[1];
  timings.mask_overrun_ms = mask_overrun_ms;

  const auto match_start = SteadyClock::now();
  SITEPOSE_TRY(StereoMatches matches, matcher_.match(left_ok, right_ok, pool_));
  timings.stereo_match_ms = ms_since(match_start);
  // The pyramids served extraction and matching only.
  left_.recycle(std::move(left_ok.pyramid));
  right_.recycle(std::move(right_ok.pyramid));
  StereoFeatures out;
  out.keypoints = std::move(left_ok.keypoints);
  out.descriptors = std::move(left_ok.descriptors);
  out.u_right = std::move(matches.u_right);
  out.depth_m = std::move(matches.depth_m);
  out.stereo_ambiguous = std::move(matches.ambiguous);
  out.stats = matches.stats;
  out.timings = timings;
  out.right_keypoints = std::move(right_ok.keypoints);
  out.right_descriptors = std::move(right_ok.descriptors);
  return out;
}

}  // namespace sitepose::features
