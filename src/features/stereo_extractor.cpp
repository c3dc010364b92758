#include "sitepose/features/stereo_extractor.hpp"

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>

#include "sitepose/core/stopwatch.hpp"

namespace sitepose::features {
namespace {

constexpr int kMaxFeatures = 100000;  // validate(OrbConfig)'s bound

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

Expected<OrbFeatures> StereoExtractor::extract_left(const cv::Mat& left, const cv::Mat& left_mask) {
  if (masked_area_features_ == 0 || left_mask.empty()) return left_.extract(left, left_mask);
  SITEPOSE_TRY(MaskSideFeatures sides, left_.extract_both_sides(left, left_mask, masked_area_features_));
  append(sides.outside, sides.inside);
  return std::move(sides.outside);
}

Expected<StereoFeatures> StereoExtractor::extract(const cv::Mat& left, const cv::Mat& right,
                                                  const cv::Mat& left_mask) {
  if (left.size() != right.size() || left.type() != right.type()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "stereo extraction: left " + std::to_string(left.cols) + "x" +
                          std::to_string(left.rows) + " type " + std::to_string(left.type()) + " and right " +
                          std::to_string(right.cols) + "x" + std::to_string(right.rows) + " type " +
                          std::to_string(right.type()) + " must have the same size and type");
  }
  // Two jobs that share nothing (separate OrbExtractor instances); the
  // matcher needs both.
  // Constructed in place (emplace), never assigned: Expected<T> has no
  // noexcept move assignment for a T holding cv::Mat.
  std::optional<Expected<OrbFeatures>> left_features;
  std::optional<Expected<OrbFeatures>> right_features;
  StereoTimings timings;
  const auto job = [&](int image) {
    const auto start = SteadyClock::now();
    if (image == 0) {
      left_features.emplace(extract_left(left, left_mask));
      timings.extract_left_ms = ms_since(start);
    } else {
      right_features.emplace(right_.extract(right));
      timings.extract_right_ms = ms_since(start);
    }
  };
  if (pool_ != nullptr) {
    pool_->run(2, job);
  } else {
    job(0);
    job(1);
  }
  if (!*left_features) return Unexpected{left_features->error()};
  if (!*right_features) return Unexpected{right_features->error()};
  OrbFeatures& left_ok = **left_features;
  OrbFeatures& right_ok = **right_features;

  const auto match_start = SteadyClock::now();
  SITEPOSE_TRY(StereoMatches matches, matcher_.match(left_ok, right_ok));
  timings.stereo_match_ms = ms_since(match_start);
  StereoFeatures out;
  out.keypoints = std::move(left_ok.keypoints);
  out.descriptors = std::move(left_ok.descriptors);
  out.left_pyramid = std::move(left_ok.pyramid);
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
