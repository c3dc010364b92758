#include "sitepose/features/stereo_extractor.hpp"

#include <future>
#include <string>
#include <utility>

namespace sitepose::features {

StereoExtractor::StereoExtractor(const config::OrbConfig& orb, const config::StereoMatchConfig& stereo,
                                 const StereoCamera& camera)
    : left_(orb), right_(orb), matcher_(stereo, camera.bf()) {}

Expected<StereoExtractor> StereoExtractor::create(const config::OrbConfig& orb,
                                                  const config::StereoMatchConfig& stereo,
                                                  const StereoCamera& camera) {
  SITEPOSE_TRY_STATUS(validate(orb));
  SITEPOSE_TRY_STATUS(StereoMatcher::create(stereo, camera.bf()));  // checks config and bf
  return StereoExtractor(orb, stereo, camera);
}

Expected<StereoFeatures> StereoExtractor::extract(const cv::Mat& left, const cv::Mat& right,
                                                  const cv::Mat& left_mask) {
  if (left.size() != right.size() || left.type() != right.type()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "stereo extraction: left " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                          " type " + std::to_string(left.type()) + " and right " + std::to_string(right.cols) +
                          "x" + std::to_string(right.rows) + " type " + std::to_string(right.type()) +
                          " must have the same size and type");
  }
  // The right image on a second thread: the two extractions share nothing
  // (separate OrbExtractor instances), and the matcher needs both.
  auto right_future = std::async(std::launch::async, [this, &right] { return right_.extract(right); });
  Expected<OrbFeatures> left_features = left_.extract(left, left_mask);
  Expected<OrbFeatures> right_features = right_future.get();
  if (!left_features) return Unexpected{left_features.error()};
  if (!right_features) return Unexpected{right_features.error()};

  SITEPOSE_TRY(StereoMatches matches, matcher_.match(*left_features, *right_features));
  StereoFeatures out;
  out.keypoints = std::move(left_features->keypoints);
  out.descriptors = std::move(left_features->descriptors);
  out.left_pyramid = std::move(left_features->pyramid);
  out.u_right = std::move(matches.u_right);
  out.depth_m = std::move(matches.depth_m);
  out.stereo_ambiguous = std::move(matches.ambiguous);
  out.stats = matches.stats;
  out.right_keypoints = std::move(right_features->keypoints);
  out.right_descriptors = std::move(right_features->descriptors);
  return out;
}

}  // namespace sitepose::features
