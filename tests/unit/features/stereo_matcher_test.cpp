#include "sitepose/features/stereo_matcher.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sitepose/features/stereo_extractor.hpp"
#include "sitepose/testing/cameras.hpp"
#include "sitepose/testing/images.hpp"

namespace sitepose::features {
namespace {

const cv::Size kSize(960, 540);
constexpr double kBf = 350.0;  // fx 700 px, baseline 0.5 m

// Three fronto-parallel row bands; the last lies beyond max_disparity_px.
const std::vector<int> kBandEnds = {180, 360, 540};
const std::vector<double> kBandDisparity = {10.3, 33.7, 80.0};

StereoCamera camera() { return testing::centred_camera(kSize.width, kSize.height, 700.0, kBf / 700.0); }

config::StereoMatchConfig stereo_config() {
  config::StereoMatchConfig cfg;
  cfg.max_disparity_px = 60.0;
  return cfg;
}

int band_of(double v) { return v < kBandEnds[0] ? 0 : v < kBandEnds[1] ? 1 : 2; }

// True when the keypoint's descriptor and SAD windows stay inside one band
// and its true match lies inside the right image.
bool clean(const cv::KeyPoint& kp, double scale) {
  const double margin = 20.0 * scale;
  for (const int end : kBandEnds) {
    if (std::abs(kp.pt.y - end) < margin) return false;
  }
  return kp.pt.x - kBandDisparity[band_of(kp.pt.y)] > margin;
}

using Pair = testing::StereoImages;

Pair make_pair(std::uint64_t seed) {
  return testing::shapes_stereo_pair(kSize, seed, kBandEnds, kBandDisparity);
}

StereoFeatures extract_ok(StereoExtractor& extractor, const Pair& pair, const cv::Mat& mask = cv::Mat()) {
  auto result = extractor.extract(pair.left, pair.right, mask);
  EXPECT_TRUE(result.has_value()) << (result ? "" : result.error().message);
  return result ? std::move(result).value() : StereoFeatures{};
}

// Disparity errors of the matched clean keypoints of the in-range bands.
struct Accuracy {
  int usable = 0;
  int matched = 0;
  int within_0_2_scale = 0;        // |error| < 0.2 px * level scale
  double worst_in_level_px = 0.0;  // max |error| / level scale
  std::vector<double> level0_abs_errors;
};

Accuracy accuracy(const StereoFeatures& f, const std::vector<double>& scales) {
  Accuracy a;
  for (int i = 0; i < f.size(); ++i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    const int band = band_of(kp.pt.y);
    if (band == 2 || !clean(kp, scales[kp.octave])) continue;
    ++a.usable;
    if (!f.has_depth(i)) continue;
    ++a.matched;
    const double disparity = kp.pt.x - f.u_right[i];
    const double error = std::abs(disparity - kBandDisparity[band]);
    a.within_0_2_scale += error < 0.2 * scales[kp.octave];
    a.worst_in_level_px = std::max(a.worst_in_level_px, error / scales[kp.octave]);
    if (kp.octave == 0) a.level0_abs_errors.push_back(error);
    EXPECT_NEAR(f.depth_m[i], kBf / disparity, 1e-9);
  }
  return a;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(StereoMatcher, RecoversKnownDisparitiesAndDepths) {
  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  const StereoFeatures f = extract_ok(extractor, make_pair(21));
  ASSERT_EQ(f.u_right.size(), f.keypoints.size());
  ASSERT_EQ(f.depth_m.size(), f.keypoints.size());
  const Accuracy a = accuracy(f, extractor.orb().scale_factors());
  ASSERT_GT(a.usable, 500);
  EXPECT_GT(a.matched, 0.5 * a.usable) << a.matched << " of " << a.usable;
  // Sub-pixel: most within 0.2 px (at the keypoint's level), no gross error.
  EXPECT_GT(a.within_0_2_scale, 0.9 * a.matched) << a.within_0_2_scale << " of " << a.matched;
  EXPECT_LT(a.worst_in_level_px, 0.4);
  ASSERT_GT(a.level0_abs_errors.size(), 50u);
  EXPECT_LT(median(a.level0_abs_errors), 0.1);
  EXPECT_EQ(f.stats.n_left, f.size());
  EXPECT_EQ(f.stats.n_matched + f.stats.n_no_candidate + f.stats.n_descriptor_too_far +
                f.stats.n_window_outside + f.stats.n_refinement_failed + f.stats.n_out_of_range +
                f.stats.n_sad_outlier,
            f.stats.n_left);
  int with_depth = 0;
  for (int i = 0; i < f.size(); ++i) with_depth += f.has_depth(i);
  EXPECT_EQ(with_depth, f.stats.n_matched);
}

TEST(StereoMatcher, NoMatchOutsideTheDisparityRange) {
  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  const Pair pair = make_pair(22);
  const StereoFeatures f = extract_ok(extractor, pair);
  const auto& scales = extractor.orb().scale_factors();
  int far_band = 0;
  for (int i = 0; i < f.size(); ++i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    if (band_of(kp.pt.y) != 2 || !clean(kp, scales[kp.octave])) continue;
    ++far_band;
    EXPECT_FALSE(f.has_depth(i)) << "band disparity 80 > max 60, matched at " << kp.pt
                                 << " d=" << kp.pt.x - f.u_right[i];
  }
  EXPECT_GT(far_band, 200);

  // Raising the minimum above the near band's disparity removes its matches.
  config::StereoMatchConfig cfg = stereo_config();
  cfg.min_disparity_px = 15.0;
  StereoExtractor raised(config::OrbConfig{}, cfg, camera());
  const StereoFeatures g = extract_ok(raised, pair);
  int band0 = 0;
  int band1_matched = 0;
  for (int i = 0; i < g.size(); ++i) {
    const cv::KeyPoint& kp = g.keypoints[i];
    if (!clean(kp, scales[kp.octave])) continue;
    if (band_of(kp.pt.y) == 0) {
      ++band0;
      EXPECT_FALSE(g.has_depth(i)) << "disparity 10.3 < min 15 matched at " << kp.pt;
    } else if (band_of(kp.pt.y) == 1 && g.has_depth(i)) {
      ++band1_matched;
    }
  }
  EXPECT_GT(band0, 200);
  EXPECT_GT(band1_matched, 120);
}

// A texture that repeats every 16 px along the rows (a facade of equal
// windows) gives every left keypoint several equally good right
// candidates inside the disparity range: its matches are flagged
// ambiguous. A random texture's are not.
TEST(StereoMatcher, RepeatedTextureFlagsMatchesAmbiguous) {
  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  auto ambiguous_fraction = [](const StereoFeatures& f) {
    int candidates = 0, ambiguous = 0;
    for (int i = 0; i < f.size(); ++i) {
      if (!f.has_depth(i) && !f.stereo_ambiguous[i]) continue;
      ++candidates;
      ambiguous += f.stereo_ambiguous[i];
    }
    return candidates > 0 ? static_cast<double>(ambiguous) / candidates : 0.0;
  };
  const StereoFeatures random = extract_ok(extractor, make_pair(31));
  ASSERT_EQ(random.stereo_ambiguous.size(), static_cast<std::size_t>(random.size()));

  constexpr int kPeriodPx = 16;
  cv::Mat tile(kSize.height, kPeriodPx, CV_8UC1);
  cv::RNG(7).fill(tile, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(tile, tile, cv::Size(3, 3), 0.8);
  Pair periodic;
  cv::repeat(tile, 1, kSize.width / kPeriodPx, periodic.left);
  periodic.right = cv::Mat::zeros(kSize, CV_8UC1);
  constexpr int kDisparityPx = 12;  // right = left shifted left
  periodic.left.colRange(kDisparityPx, kSize.width)
      .copyTo(periodic.right.colRange(0, kSize.width - kDisparityPx));
  const StereoFeatures repeated = extract_ok(extractor, periodic);

  const double random_fraction = ambiguous_fraction(random);
  const double repeated_fraction = ambiguous_fraction(repeated);
  std::printf("ambiguous: random texture %.3f, repeated texture %.3f\n", random_fraction, repeated_fraction);
  EXPECT_LT(random_fraction, 0.15);
  EXPECT_GT(repeated_fraction, 0.5);
}

TEST(StereoMatcher, InconsistentMatchesAreRejectedBySad) {
  // Heavy noise on part of the right image: descriptors (computed on the
  // blurred image) still agree, but the SAD cost of those matches is far
  // above the median and the median rule must reject them.
  Pair pair = make_pair(23);
  const cv::Rect noisy(480, 180, 480, 180);  // right half of band 1
  cv::Mat noise(noisy.size(), CV_16SC1);
  cv::RNG(5).fill(noise, cv::RNG::NORMAL, 0, 40);
  cv::Mat region;
  pair.right(noisy).convertTo(region, CV_16SC1);
  region += noise;
  region.convertTo(pair.right(noisy), CV_8UC1);

  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  const StereoFeatures f = extract_ok(extractor, pair);
  const auto& scales = extractor.orb().scale_factors();
  int clean_total = 0;
  int clean_matched = 0;
  int noisy_total = 0;
  int noisy_matched = 0;
  for (int i = 0; i < f.size(); ++i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    const int band = band_of(kp.pt.y);
    if (band == 2 || !clean(kp, scales[kp.octave])) continue;
    // Left keypoints whose right window lies in the noisy part.
    const double u_true = kp.pt.x - kBandDisparity[band];
    const bool in_noise = band == 1 && u_true > noisy.x + 20.0 * scales[kp.octave];
    const bool near_noise = band == 1 && u_true > noisy.x - 30.0 * scales[kp.octave];
    if (in_noise) {
      ++noisy_total;
      noisy_matched += f.has_depth(i);
    } else if (!near_noise) {
      ++clean_total;
      clean_matched += f.has_depth(i);
    }
  }
  ASSERT_GT(noisy_total, 50);
  EXPECT_GT(f.stats.n_sad_outlier, noisy_total / 2);
  EXPECT_LT(noisy_matched, 0.25 * noisy_total) << noisy_matched << " of " << noisy_total;
  EXPECT_GT(clean_matched, 0.45 * clean_total) << clean_matched << " of " << clean_total;
}

TEST(StereoMatcher, ZeroMeanSadToleratesABrightnessOffset) {
  const Pair pair = make_pair(24);
  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  const Accuracy same = accuracy(extract_ok(extractor, pair), extractor.orb().scale_factors());
  Pair brighter = pair;
  brighter.right.convertTo(brighter.right, CV_8UC1, 1.0, 35.0);  // right camera exposes brighter
  const Accuracy offset = accuracy(extract_ok(extractor, brighter), extractor.orb().scale_factors());
  EXPECT_GT(offset.matched, 0.9 * same.matched) << offset.matched << " vs " << same.matched;
  EXPECT_GT(offset.within_0_2_scale, 0.9 * offset.matched);
  EXPECT_LT(offset.worst_in_level_px, 0.4);
}

TEST(StereoMatcher, LeftMaskAppliesToLeftOnly) {
  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  const Pair pair = make_pair(25);
  cv::Mat mask = cv::Mat::zeros(kSize, CV_8UC1);
  mask(cv::Rect(200, 0, 300, 540)).setTo(255);
  const StereoFeatures f = extract_ok(extractor, pair, mask);
  ASSERT_GT(f.size(), 1000);
  for (const auto& kp : f.keypoints) {
    ASSERT_EQ(mask.at<std::uint8_t>(int(std::lround(kp.pt.y)), int(std::lround(kp.pt.x))), 0);
  }
  const auto right_in_mask =
      std::count_if(f.right_keypoints.begin(), f.right_keypoints.end(),
                    [](const cv::KeyPoint& kp) { return kp.pt.x > 220 && kp.pt.x < 480; });
  EXPECT_GT(right_in_mask, 100);
  EXPECT_EQ(f.right_descriptors.rows, static_cast<int>(f.right_keypoints.size()));
}

// One-level features at the given level-0 positions, all with the same
// descriptor (so the descriptor match is the only right keypoint in reach).
OrbFeatures one_level_features(const cv::Mat& image, const std::vector<cv::Point2f>& positions) {
  OrbFeatures f;
  f.pyramid.levels = {image};
  f.pyramid.ratio_x = {1.0};
  f.pyramid.ratio_y = {1.0};
  for (const cv::Point2f& p : positions) f.keypoints.emplace_back(p, 31.0f, 0.0f, 0.0f, 0);
  f.descriptors = cv::Mat::zeros(static_cast<int>(positions.size()), 32, CV_8UC1);
  return f;
}

// The refinement compares shifts -5..-1 with the previous keypoint's cost
// at shift 0 until one of its own shifts wins (the rule documented in
// stereo_matcher.cpp; the plain minimum measured worse). Random texture,
// right = left shifted by 20 px; keypoint 0's right keypoint sits on its
// true match (cost 0 at shift 0), keypoint 1's 2 px right of it (its
// minimum at shift -2, also cost 0, so it cannot beat keypoint 0's 0).
// With and without a pool (the carried cost crosses the pool's runs).
TEST(StereoMatcher, RefinementComparesEarlyShiftsWithThePreviousCostAtZero) {
  constexpr int kDisparityPx = 20;
  cv::Mat left(200, 400, CV_8UC1);
  cv::RNG(7).fill(left, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(left, left, cv::Size(3, 3), 0.8);
  cv::Mat right = cv::Mat::zeros(left.size(), CV_8UC1);
  left(cv::Rect(kDisparityPx, 0, left.cols - kDisparityPx, left.rows))
      .copyTo(right(cv::Rect(0, 0, left.cols - kDisparityPx, left.rows)));
  const OrbFeatures left_features = one_level_features(left, {{150.0f, 80.0f}, {250.0f, 120.0f}});
  const OrbFeatures right_features =
      one_level_features(right, {{150.0f - kDisparityPx, 80.0f}, {250.0f - kDisparityPx + 2.0f, 120.0f}});
  config::StereoMatchConfig cfg = stereo_config();
  cfg.row_band_px = 1;
  const StereoMatcher matcher(cfg, kBf);
  TaskPool one_worker(1);
  for (TaskPool* pool : {static_cast<TaskPool*>(nullptr), &one_worker}) {
    const auto matches = matcher.match(left_features, right_features, pool);
    ASSERT_TRUE(matches.has_value()) << matches.error().message;
    // Sub-pixel: the parabola through unequal neighbours moves the vertex
    // a little off the integer minimum.
    EXPECT_NEAR(matches->u_right[0], 150.0 - kDisparityPx, 0.3);
    EXPECT_GT(std::abs(matches->u_right[1] - (250.0 - kDisparityPx)), 1.0) << matches->u_right[1];
  }
}

TEST(StereoMatcher, SadOutlierThresholdIsScaledMedian) {
  EXPECT_DOUBLE_EQ(sad_outlier_threshold({1.0, 2.0, 3.0, 4.0, 100.0}), 1.5 * 1.4 * 3.0);
  EXPECT_DOUBLE_EQ(sad_outlier_threshold({5.0}), 1.5 * 1.4 * 5.0);
  EXPECT_DOUBLE_EQ(sad_outlier_threshold({}), 0.0);
}

TEST(StereoMatcher, RejectsBadConfigAndInputs) {
  config::StereoMatchConfig cfg = stereo_config();
  cfg.max_disparity_px = 0.2;
  auto status = validate(cfg);
  ASSERT_FALSE(status.has_value());
  EXPECT_NE(status.error().message.find("stereo.max_disparity_px = 0.2"), std::string::npos)
      << status.error().message;
  EXPECT_FALSE(StereoMatcher::create(stereo_config(), 0.0).has_value());
  StereoCamera no_baseline = camera();
  no_baseline.baseline_m = 0.0;
  EXPECT_FALSE(StereoExtractor::create(config::OrbConfig{}, stereo_config(), no_baseline).has_value());

  StereoExtractor extractor(config::OrbConfig{}, stereo_config(), camera());
  const cv::Mat left = testing::make_texture(kSize, 26);
  const auto mismatched = extractor.extract(left, left(cv::Rect(0, 0, 480, 540)).clone());
  ASSERT_FALSE(mismatched.has_value());
  EXPECT_EQ(mismatched.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace sitepose::features
