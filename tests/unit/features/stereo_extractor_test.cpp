#include "sitepose/features/stereo_extractor.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "sitepose/testing/cameras.hpp"
#include "sitepose/testing/images.hpp"

namespace sitepose::features {
namespace {

const cv::Size kSize(960, 540);

using Pair = testing::StereoImages;

Pair shapes_pair(std::uint64_t seed) {
  return testing::shapes_stereo_pair(kSize, seed, {270, 540}, {12.4, 31.6});
}

StereoExtractor make_extractor(TaskPool* pool, int masked_area_features = 0) {
  const StereoCamera camera = testing::centred_camera(kSize.width, kSize.height, 700.0, 0.5);
  StereoExtractorOptions options;
  options.pool = pool;
  options.masked_area_features = masked_area_features;
  return StereoExtractor(config::OrbConfig{}, config::StereoMatchConfig{}, camera, options);
}

StereoFeatures extract_ok(StereoExtractor& extractor, const Pair& pair, const cv::Mat& mask = {}) {
  auto result = extractor.extract(pair.left, pair.right, mask);
  EXPECT_TRUE(result.has_value()) << (result ? "" : result.error().message);
  return result ? std::move(result).value() : StereoFeatures{};
}

bool same_keypoints(const std::vector<cv::KeyPoint>& a, const std::vector<cv::KeyPoint>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].pt != b[i].pt || a[i].octave != b[i].octave || a[i].angle != b[i].angle ||
        a[i].response != b[i].response || a[i].size != b[i].size) {
      return false;
    }
  }
  return true;
}

bool same_rows(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0.0);
}

void expect_identical(const StereoFeatures& a, const StereoFeatures& b) {
  EXPECT_TRUE(same_keypoints(a.keypoints, b.keypoints));
  EXPECT_TRUE(same_rows(a.descriptors, b.descriptors));
  EXPECT_EQ(a.u_right, b.u_right);
  EXPECT_EQ(a.depth_m, b.depth_m);
  EXPECT_EQ(a.stereo_ambiguous, b.stereo_ambiguous);
  EXPECT_EQ(a.stats.n_matched, b.stats.n_matched);
  EXPECT_EQ(a.stats.n_no_candidate, b.stats.n_no_candidate);
  EXPECT_EQ(a.stats.n_descriptor_too_far, b.stats.n_descriptor_too_far);
  EXPECT_EQ(a.stats.n_window_outside, b.stats.n_window_outside);
  EXPECT_EQ(a.stats.n_refinement_failed, b.stats.n_refinement_failed);
  EXPECT_EQ(a.stats.n_out_of_range, b.stats.n_out_of_range);
  EXPECT_EQ(a.stats.n_sad_outlier, b.stats.n_sad_outlier);
  EXPECT_TRUE(same_keypoints(a.right_keypoints, b.right_keypoints));
  EXPECT_TRUE(same_rows(a.right_descriptors, b.right_descriptors));
}

cv::Mat band_mask() {
  cv::Mat mask = cv::Mat::zeros(kSize, CV_8UC1);
  mask(cv::Rect(300, 100, 250, 300)).setTo(255);
  return mask;
}

bool in_mask(const cv::Mat& mask, const cv::KeyPoint& kp) {
  return mask.at<std::uint8_t>(static_cast<int>(std::lround(kp.pt.y)),
                               static_cast<int>(std::lround(kp.pt.x))) != 0;
}

TEST(StereoExtractor, PooledAndSerialGiveIdenticalFeatures) {
  TaskPool pool(2);
  StereoExtractor pooled = make_extractor(&pool, 300);
  StereoExtractor serial = make_extractor(nullptr, 300);
  for (const std::uint64_t seed : {31u, 32u}) {
    const Pair pair = shapes_pair(seed);
    const StereoFeatures a = extract_ok(pooled, pair);
    const StereoFeatures b = extract_ok(serial, pair);
    ASSERT_GT(a.size(), 1000);
    EXPECT_GT(a.stats.n_matched, 500);
    expect_identical(a, b);
    // The same extractor again on the same pair: nothing carried over.
    expect_identical(extract_ok(pooled, pair), a);
    expect_identical(extract_ok(pooled, pair, band_mask()), extract_ok(serial, pair, band_mask()));
  }
}

TEST(StereoExtractor, MaskedAreaGetsItsOwnBudgetAfterTheRest) {
  TaskPool pool(1);
  StereoExtractor with_share = make_extractor(&pool, 300);
  StereoExtractor without = make_extractor(&pool, 0);
  const Pair pair = shapes_pair(33);
  const cv::Mat mask = band_mask();
  const StereoFeatures shared = extract_ok(with_share, pair, mask);
  const StereoFeatures masked_only = extract_ok(without, pair, mask);
  for (const cv::KeyPoint& kp : masked_only.keypoints) ASSERT_FALSE(in_mask(mask, kp));
  // The background part is the same extraction; the masked area's
  // keypoints follow it, all inside the mask, at most its budget.
  const int n_background = masked_only.size();
  ASSERT_GT(shared.size(), n_background + 150);
  EXPECT_LE(shared.size(), n_background + 300);
  EXPECT_TRUE(same_keypoints({shared.keypoints.begin(), shared.keypoints.begin() + n_background},
                             masked_only.keypoints));
  for (int i = n_background; i < shared.size(); ++i) EXPECT_TRUE(in_mask(mask, shared.keypoints[i])) << i;
  EXPECT_EQ(shared.descriptors.rows, shared.size());
  EXPECT_TRUE(same_rows(shared.descriptors.rowRange(0, n_background), masked_only.descriptors));
  // An all-zero mask is no mask: no masked area, the full budget unmasked.
  expect_identical(extract_ok(with_share, pair, cv::Mat::zeros(kSize, CV_8UC1)), extract_ok(without, pair));
}

TEST(StereoExtractor, ReportsTheTimeOfEachStep) {
  TaskPool pool(1);
  StereoExtractor extractor = make_extractor(&pool);
  const StereoFeatures f = extract_ok(extractor, shapes_pair(34));
  EXPECT_GT(f.timings.extract_left_ms, 0.0);
  EXPECT_GT(f.timings.extract_right_ms, 0.0);
  EXPECT_GT(f.timings.stereo_match_ms, 0.0);
}

TEST(StereoExtractor, RejectsABadMaskAndBudget) {
  StereoExtractor extractor = make_extractor(nullptr, 300);
  const Pair pair = shapes_pair(35);
  EXPECT_FALSE(extractor.extract(pair.left, pair.right, cv::Mat::zeros(kSize, CV_8UC3)).has_value());
  EXPECT_FALSE(extractor.extract(pair.left, pair.right, cv::Mat::zeros(10, 10, CV_8UC1)).has_value());
  const StereoCamera camera = testing::centred_camera(kSize.width, kSize.height, 700.0, 0.5);
  StereoExtractorOptions options;
  options.masked_area_features = -1;
  EXPECT_FALSE(
      StereoExtractor::create(config::OrbConfig{}, config::StereoMatchConfig{}, camera, options).has_value());
  options.masked_area_features = 300;
  EXPECT_TRUE(
      StereoExtractor::create(config::OrbConfig{}, config::StereoMatchConfig{}, camera, options).has_value());
}

// A mask made by a maker (a detector's segmentation) runs on the calling
// thread beside the pyramids and gives what the same mask given directly
// gives; the maker's error, or a bad mask it makes, is returned.
TEST(StereoExtractor, AMaskMadeBesideThePyramidsGivesTheSameFeatures) {
  TaskPool pool(1);
  StereoExtractor extractor = make_extractor(&pool, 300);
  const Pair pair = shapes_pair(36);
  const auto caller = std::this_thread::get_id();
  int made = 0;
  const auto maker = [&]() -> Expected<cv::Mat> {
    EXPECT_EQ(std::this_thread::get_id(), caller);
    ++made;
    return band_mask();
  };
  auto from_maker = extractor.extract(pair.left, pair.right, maker);
  ASSERT_TRUE(from_maker.has_value()) << from_maker.error().message;
  EXPECT_EQ(made, 1);
  expect_identical(*from_maker, extract_ok(extractor, pair, band_mask()));

  const auto failing = []() -> Expected<cv::Mat> {
    return make_error(ErrorCode::kInvalidArgument, "detector: no model");
  };
  auto failed = extractor.extract(pair.left, pair.right, failing);
  ASSERT_FALSE(failed.has_value());
  EXPECT_EQ(failed.error().message, "detector: no model");
  const auto bad_mask = []() -> Expected<cv::Mat> { return cv::Mat(cv::Mat::zeros(10, 10, CV_8UC1)); };
  EXPECT_FALSE(extractor.extract(pair.left, pair.right, bad_mask).has_value());
  // The extractor still works afterwards.
  expect_identical(extract_ok(extractor, pair, band_mask()), *from_maker);

  // A slow maker: the frame waits on it beyond the pyramids (about 1 ms).
  const auto slow = []() -> Expected<cv::Mat> {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return band_mask();
  };
  auto waited = extractor.extract(pair.left, pair.right, slow);
  ASSERT_TRUE(waited.has_value());
  EXPECT_GE(waited->timings.mask_overrun_ms, 50.0);
}

}  // namespace
}  // namespace sitepose::features
