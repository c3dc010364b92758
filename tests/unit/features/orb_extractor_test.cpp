#include "sitepose/features/orb_extractor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "sitepose/features/hamming.hpp"
#include "sitepose/testing/images.hpp"

namespace sitepose::features {
namespace {

const cv::Size kSize(960, 540);

OrbFeatures extract_ok(OrbExtractor& extractor, const cv::Mat& image, const cv::Mat& mask = cv::Mat()) {
  auto result = extractor.extract(image, mask);
  EXPECT_TRUE(result.has_value()) << (result ? "" : result.error().message);
  return result ? std::move(result).value() : OrbFeatures{};
}

bool masked_at(const cv::Mat& mask, const cv::KeyPoint& kp) {
  const int u = static_cast<int>(std::lround(kp.pt.x));
  const int v = static_cast<int>(std::lround(kp.pt.y));
  return mask.at<std::uint8_t>(v, u) != 0;
}

// Keypoint counts of a rows x cols grid over the image.
std::vector<int> grid_counts(const std::vector<cv::KeyPoint>& kps, cv::Size size, int cols, int rows) {
  std::vector<int> counts(cols * rows, 0);
  for (const auto& kp : kps) {
    const int c = std::clamp(static_cast<int>(kp.pt.x * cols / size.width), 0, cols - 1);
    const int r = std::clamp(static_cast<int>(kp.pt.y * rows / size.height), 0, rows - 1);
    ++counts[r * cols + c];
  }
  return counts;
}

TEST(OrbExtractor, ReturnsBudgetWithConsistentFields) {
  config::OrbConfig cfg;
  OrbExtractor extractor(cfg);
  const cv::Mat image = testing::make_texture(kSize, 1);
  const OrbFeatures f = extract_ok(extractor, image);
  const int n = static_cast<int>(f.keypoints.size());
  EXPECT_LE(n, cfg.n_features);
  EXPECT_GE(n, cfg.n_features * 95 / 100);
  ASSERT_EQ(f.descriptors.rows, n);
  EXPECT_EQ(f.descriptors.cols, kDescriptorBytes);
  EXPECT_EQ(f.descriptors.type(), CV_8UC1);
  std::vector<int> per_level(cfg.n_levels, 0);
  for (const auto& kp : f.keypoints) {
    ASSERT_GE(kp.octave, 0);
    ASSERT_LT(kp.octave, cfg.n_levels);
    ++per_level[kp.octave];
    EXPECT_GE(kp.angle, 0.0f);
    EXPECT_LT(kp.angle, 360.0f);
    EXPECT_GE(kp.response, float(cfg.min_fast_threshold));
    EXPECT_NEAR(kp.size, 31.0 * std::pow(cfg.scale_factor, kp.octave), 1e-3);
    EXPECT_TRUE(kp.pt.x >= 0 && kp.pt.y >= 0 && kp.pt.x < kSize.width && kp.pt.y < kSize.height);
  }
  // Geometric budget: every level used, finer levels get more.
  for (int l = 0; l < cfg.n_levels; ++l) EXPECT_GT(per_level[l], 0) << "level " << l;
  EXPECT_GT(per_level[0], per_level[cfg.n_levels - 1]);
  EXPECT_EQ(f.pyramid.n_levels(), cfg.n_levels);
}

TEST(OrbExtractor, AStrongFirstFastPassIsOffAtOrBelowTheInitialThreshold) {
  const cv::Mat image = testing::make_texture(kSize, 2);
  config::OrbConfig cfg;
  OrbExtractor plain(cfg);
  const OrbFeatures reference = extract_ok(plain, image);
  cfg.strong_fast_threshold = cfg.ini_fast_threshold;
  OrbExtractor at_ini(cfg);
  const OrbFeatures same = extract_ok(at_ini, image);
  ASSERT_EQ(same.keypoints.size(), reference.keypoints.size());
  for (std::size_t i = 0; i < same.keypoints.size(); ++i) {
    EXPECT_EQ(same.keypoints[i].pt, reference.keypoints[i].pt) << i;
  }
  // Above it, the textured cells keep only their strong corners: the full
  // budget, from other candidates.
  cfg.strong_fast_threshold = 60;
  OrbExtractor strong(cfg);
  const OrbFeatures other = extract_ok(strong, image);
  EXPECT_EQ(other.keypoints.size(), reference.keypoints.size());
  int moved = 0;
  for (std::size_t i = 0; i < other.keypoints.size() && i < reference.keypoints.size(); ++i) {
    moved += other.keypoints[i].pt != reference.keypoints[i].pt;
  }
  EXPECT_GT(moved, 0);
}

TEST(OrbExtractor, LevelScaleTables) {
  config::OrbConfig cfg;
  cfg.scale_factor = 1.3;
  cfg.n_levels = 5;
  OrbExtractor extractor(cfg);
  ASSERT_EQ(extractor.scale_factors().size(), 5u);
  int budget = 0;
  for (int l = 0; l < 5; ++l) {
    const double s = std::pow(1.3, l);
    EXPECT_NEAR(extractor.scale_factors()[l], s, 1e-12);
    EXPECT_NEAR(extractor.inv_scale_factors()[l], 1.0 / s, 1e-12);
    EXPECT_NEAR(extractor.level_sigma2()[l], s * s, 1e-12);
    EXPECT_NEAR(extractor.inv_level_sigma2()[l], 1.0 / (s * s), 1e-12);
    budget += extractor.features_per_level()[l];
    if (l > 0) {
      EXPECT_LT(extractor.features_per_level()[l], extractor.features_per_level()[l - 1]);
    }
  }
  EXPECT_EQ(budget, cfg.n_features);
}

TEST(OrbExtractor, NoKeypointOnAMaskedPixel) {
  OrbExtractor extractor(config::OrbConfig{});
  const cv::Mat image = testing::make_texture(kSize, 2);
  cv::Mat mask = cv::Mat::zeros(kSize, CV_8UC1);
  cv::RNG rng(7);
  for (int i = 0; i < 25; ++i) {
    cv::circle(mask, cv::Point(rng.uniform(0, kSize.width), rng.uniform(0, kSize.height)),
               rng.uniform(10, 90), cv::Scalar(255), cv::FILLED);
  }
  cv::rectangle(mask, cv::Rect(300, 100, 1, 400), cv::Scalar(1), cv::FILLED);  // 1-px line, value 1
  const OrbFeatures f = extract_ok(extractor, image, mask);
  ASSERT_GT(f.keypoints.size(), 1000u);
  int near_mask = 0;
  for (const auto& kp : f.keypoints) {
    ASSERT_FALSE(masked_at(mask, kp)) << "keypoint at " << kp.pt << " level " << kp.octave;
    // Count keypoints right next to masked pixels: the mask must be exact,
    // not dilated.
    const int u = static_cast<int>(std::lround(kp.pt.x));
    const int v = static_cast<int>(std::lround(kp.pt.y));
    const cv::Rect around = cv::Rect(u - 2, v - 2, 5, 5) & cv::Rect(0, 0, kSize.width, kSize.height);
    if (cv::countNonZero(mask(around)) > 0) ++near_mask;
  }
  EXPECT_GT(near_mask, 5);
  // Without the mask, plenty of keypoints land on those pixels.
  const OrbFeatures unmasked = extract_ok(extractor, image);
  const auto on_mask = std::count_if(unmasked.keypoints.begin(), unmasked.keypoints.end(),
                                     [&](const cv::KeyPoint& kp) { return masked_at(mask, kp); });
  EXPECT_GT(on_mask, 100);
}

TEST(OrbExtractor, MaskMovesBudgetToUnmaskedHalf) {
  config::OrbConfig cfg;
  OrbExtractor extractor(cfg);
  const cv::Mat image = testing::make_texture(kSize, 3);
  cv::Mat mask = cv::Mat::zeros(kSize, CV_8UC1);
  mask(cv::Rect(0, 0, kSize.width / 2, kSize.height)).setTo(255);

  auto count_right_half = [&](const OrbFeatures& f) {
    return std::count_if(f.keypoints.begin(), f.keypoints.end(),
                         [&](const cv::KeyPoint& kp) { return std::lround(kp.pt.x) >= kSize.width / 2; });
  };
  const OrbFeatures full = extract_ok(extractor, image);
  const OrbFeatures half = extract_ok(extractor, image, mask);
  const auto right_full = count_right_half(full);
  const auto right_half = count_right_half(half);
  EXPECT_EQ(right_half, static_cast<long>(half.keypoints.size()));  // nothing in the masked half
  // The whole budget (nearly) goes to the unmasked half.
  EXPECT_GT(right_half, 17 * right_full / 10) << right_full << " -> " << right_half;
  EXPECT_GT(static_cast<int>(half.keypoints.size()), cfg.n_features * 9 / 10);
}

void expect_identical(const OrbFeatures& a, const OrbFeatures& b, const char* what) {
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size()) << what;
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    const cv::KeyPoint& p = a.keypoints[i];
    const cv::KeyPoint& q = b.keypoints[i];
    ASSERT_TRUE(p.pt == q.pt && p.angle == q.angle && p.response == q.response && p.octave == q.octave &&
                p.size == q.size)
        << what << " keypoint " << i;
  }
  ASSERT_EQ(a.descriptors.rows, b.descriptors.rows) << what;
  if (a.descriptors.rows > 0) {
    EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_L1), 0.0) << what;
  }
}

// The mask's scratch buffers pass from one extraction to the next: an
// extractor that has already extracted with other masks (and other image
// sizes) returns what a fresh one returns. Faint texture below row 300, so
// that cells fall back to the minimum threshold, where the mask's pixel
// counts decide which cells are searched.
TEST(OrbExtractor, MaskBuffersCarriedBetweenExtractionsLeaveNoTrace) {
  const cv::Mat image =
      testing::with_contrast(testing::make_texture(kSize, 5), cv::Rect(0, 0, kSize.width, 300), 0.1);
  cv::Mat mask = cv::Mat::zeros(kSize, CV_8UC1);
  cv::rectangle(mask, cv::Rect(100, 80, 300, 200), cv::Scalar(255), cv::FILLED);
  cv::Mat other_mask = cv::Mat::zeros(kSize, CV_8UC1);
  cv::rectangle(other_mask, cv::Rect(0, 0, kSize.width / 2, kSize.height), cv::Scalar(255), cv::FILLED);
  const cv::Size small(kSize.width / 2, kSize.height / 2);
  cv::Mat small_image;
  cv::resize(image, small_image, small);
  cv::Mat small_mask = cv::Mat::zeros(small, CV_8UC1);
  cv::rectangle(small_mask, cv::Rect(small.width / 2, 0, small.width / 2, small.height), cv::Scalar(255),
                cv::FILLED);

  config::OrbConfig cfg;
  OrbExtractor fresh(cfg);
  const OrbFeatures expected = extract_ok(fresh, image, mask);
  OrbExtractor used(cfg);
  extract_ok(used, image, other_mask);
  extract_ok(used, small_image, small_mask);
  extract_ok(used, image, cv::Mat());
  expect_identical(extract_ok(used, image, mask), expected, "after other masks");
  expect_identical(extract_ok(used, image, mask), expected, "again");
}

// A recycled pyramid's levels are resized into by the next extraction: the
// result is a fresh extractor's (also after another image size), and a
// level that the caller still shares is left alone, not written into.
TEST(OrbExtractor, RecycledPyramidLeavesNoTraceAndSharedLevelsAreNotReused) {
  const cv::Mat image = testing::make_texture(kSize, 5);
  const cv::Mat other_image = testing::make_texture(kSize, 6);
  cv::Mat small_image;
  cv::resize(other_image, small_image, cv::Size(kSize.width / 2, kSize.height / 2));

  config::OrbConfig cfg;
  OrbExtractor fresh(cfg);
  const OrbFeatures expected = extract_ok(fresh, image);
  OrbExtractor used(cfg);
  used.recycle(extract_ok(used, small_image).pyramid);
  OrbFeatures other = extract_ok(used, other_image);
  const std::uint8_t* recycled_data = other.pyramid.levels[1].data;
  used.recycle(std::move(other.pyramid));
  const OrbFeatures again = extract_ok(used, image);
  EXPECT_EQ(again.pyramid.levels[1].data, recycled_data);  // resized into, not allocated
  expect_identical(again, expected, "after recycled pyramids");

  OrbFeatures kept = extract_ok(used, other_image);
  const cv::Mat shared_level = kept.pyramid.levels[1];  // the caller still holds this one
  const cv::Mat level_before = shared_level.clone();
  used.recycle(std::move(kept.pyramid));
  const OrbFeatures next = extract_ok(used, image);
  EXPECT_NE(next.pyramid.levels[1].data, shared_level.data);
  EXPECT_EQ(cv::norm(shared_level, level_before, cv::NORM_INF), 0.0);
  expect_identical(next, expected, "with a shared level");
}

TEST(OrbExtractor, BothSidesInOnePassEqualTwoSeparateExtractions) {
  // Texture, faint below row 300 (cells fall back to the minimum threshold
  // on both sides of the mask), and a mask of blobs plus a 1-px line of
  // value 1.
  const cv::Mat texture = testing::make_texture(kSize, 4);
  const cv::Mat image = testing::with_contrast(texture, cv::Rect(0, 0, kSize.width, 300), 0.1);
  cv::Mat mask = cv::Mat::zeros(kSize, CV_8UC1);
  cv::RNG rng(9);
  for (int i = 0; i < 12; ++i) {
    cv::circle(mask, cv::Point(rng.uniform(0, kSize.width), rng.uniform(0, kSize.height)),
               rng.uniform(20, 120), cv::Scalar(255), cv::FILLED);
  }
  cv::rectangle(mask, cv::Rect(500, 50, 1, 400), cv::Scalar(1), cv::FILLED);
  const cv::Mat inverse = mask == 0;

  config::OrbConfig cfg;
  config::OrbConfig inside_cfg = cfg;
  inside_cfg.n_features = 600;
  OrbExtractor outside_only(cfg);
  OrbExtractor inside_only(inside_cfg);
  const OrbFeatures outside = extract_ok(outside_only, image, mask);
  const OrbFeatures inside = extract_ok(inside_only, image, inverse);
  ASSERT_GT(inside.keypoints.size(), 300u);

  TaskPool pool(1);
  for (TaskPool* lent : {static_cast<TaskPool*>(nullptr), &pool}) {
    OrbExtractor both(cfg, lent);
    auto sides = both.extract_both_sides(image, mask, inside_cfg.n_features);
    ASSERT_TRUE(sides.has_value()) << sides.error().message;
    expect_identical(sides->outside, outside, "outside");
    expect_identical(sides->inside, inside, "inside");
    EXPECT_EQ(sides->outside.pyramid.n_levels(), cfg.n_levels);
  }
  OrbExtractor both(cfg);
  EXPECT_FALSE(both.extract_both_sides(image, mask, 0).has_value());
}

TEST(OrbExtractor, SpreadsOverTheGridWherePlainFastClusters) {
  config::OrbConfig cfg;
  OrbExtractor extractor(cfg);
  // Strong texture only in the top-left quadrant, weak (but detectable by
  // the minimum threshold) elsewhere.
  const cv::Mat image = testing::with_contrast(testing::make_texture(kSize, 4),
                                               cv::Rect(0, 0, kSize.width / 2, kSize.height / 2), 0.12);
  const OrbFeatures f = extract_ok(extractor, image);
  const std::vector<int> ours = grid_counts(f.keypoints, kSize, 4, 4);

  std::vector<cv::KeyPoint> plain;
  cv::FAST(image, plain, cfg.min_fast_threshold, true);
  cv::KeyPointsFilter::retainBest(plain, cfg.n_features);
  const std::vector<int> theirs = grid_counts(plain, kSize, 4, 4);

  const int ours_min = *std::min_element(ours.begin(), ours.end());
  const int theirs_min = *std::min_element(theirs.begin(), theirs.end());
  const double mean = double(cfg.n_features) / 16.0;
  EXPECT_GT(ours_min, 0.4 * mean) << "a 4x4 cell got too few features";
  EXPECT_LT(theirs_min, 0.05 * mean) << "plain FAST top-N was expected to cluster";
}

TEST(OrbExtractor, FallbackThresholdFindsFeaturesInTexturePoorImage) {
  config::OrbConfig cfg;
  OrbExtractor extractor(cfg);
  // Contrast so low that hardly any corner passes 20, many pass 7.
  const cv::Mat image = testing::with_contrast(testing::make_texture(kSize, 5), cv::Rect(), 0.1);
  std::vector<cv::KeyPoint> strong;
  cv::FAST(image, strong, cfg.ini_fast_threshold, true);
  const OrbFeatures f = extract_ok(extractor, image);
  EXPECT_LT(strong.size(), 100u);
  EXPECT_GT(f.keypoints.size(), static_cast<size_t>(cfg.n_features * 8 / 10));
}

TEST(OrbExtractor, IntensityCentroidAngleFollowsRotation) {
  // An off-centre bright blob on a ramp: a well-defined centroid direction.
  cv::Mat patch(201, 201, CV_8UC1, cv::Scalar(40));
  cv::circle(patch, cv::Point(110, 96), 6, cv::Scalar(250), cv::FILLED);
  for (int y = 0; y < patch.rows; ++y) {
    for (int x = 0; x < patch.cols; ++x) patch.at<std::uint8_t>(y, x) += static_cast<std::uint8_t>(x / 4);
  }
  cv::GaussianBlur(patch, patch, cv::Size(0, 0), 1.5);
  const cv::Point2f center(100, 100);
  const double angle0 = intensity_centroid_angle_deg(patch, 100, 100);
  for (const double rotation_deg : {25.0, 90.0, 160.0, 235.0, 310.0}) {
    cv::Mat rotated;
    // Positive = counter-clockwise on screen = clockwise in y-down image
    // axes, so the centroid angle must drop by rotation_deg.
    cv::warpAffine(patch, rotated, cv::getRotationMatrix2D(center, rotation_deg, 1.0), patch.size(),
                   cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    const double angle = intensity_centroid_angle_deg(rotated, 100, 100);
    double delta = std::fmod(angle0 - angle - rotation_deg + 720.0, 360.0);
    if (delta > 180.0) delta -= 360.0;
    EXPECT_NEAR(delta, 0.0, 3.0) << "rotation " << rotation_deg << ": " << angle0 << " -> " << angle;
  }
}

// Pairs keypoints of `a` with those of `b` at a's position mapped by `to_b`
// (same level, within tol_px). Returns Hamming distances and angle changes.
template <typename Map>
void corresponding(const OrbFeatures& a, const OrbFeatures& b, Map to_b, double tol_px,
                   std::vector<int>* distances, std::vector<double>* angle_changes) {
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    const cv::Point2f target = to_b(a.keypoints[i].pt);
    for (size_t j = 0; j < b.keypoints.size(); ++j) {
      const cv::KeyPoint& kb = b.keypoints[j];
      if (kb.octave != a.keypoints[i].octave) continue;
      if (std::abs(kb.pt.x - target.x) > tol_px || std::abs(kb.pt.y - target.y) > tol_px) continue;
      distances->push_back(hamming_distance(a.descriptors, int(i), b.descriptors, int(j)));
      angle_changes->push_back(kb.angle - a.keypoints[i].angle);
      break;
    }
  }
}

int median(std::vector<int> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(OrbExtractor, DescriptorsOfShiftedSceneMatch) {
  OrbExtractor extractor(config::OrbConfig{});
  const cv::Mat canvas = testing::make_texture(cv::Size(1000, 600), 6);
  const cv::Mat a = canvas(cv::Rect(24, 30, 960, 540)).clone();
  // Scene moves by (+24, +12): whole pixels on levels 0 and 1 (24 / 1.2,
  // 12 / 1.2), so keypoints there land on exactly corresponding pixels.
  const cv::Mat b = canvas(cv::Rect(0, 18, 960, 540)).clone();
  const OrbFeatures fa = extract_ok(extractor, a);
  const OrbFeatures fb = extract_ok(extractor, b);
  std::vector<int> distances;
  std::vector<double> angle_changes;
  corresponding(
      fa, fb, [](cv::Point2f p) { return p + cv::Point2f(24, 12); }, 0.01, &distances, &angle_changes);
  ASSERT_GT(distances.size(), 300u);
  EXPECT_LE(median(distances), 2);
  // Unrelated keypoints are ~128 bits apart.
  std::vector<int> unrelated;
  for (int i = 0; i < 200; ++i)
    unrelated.push_back(hamming_distance(fa.descriptors, i, fb.descriptors, i + 300));
  EXPECT_GT(median(unrelated), 90);
}

TEST(OrbExtractor, DescriptorsAreSteeredByOrientation) {
  OrbExtractor extractor(config::OrbConfig{});
  const cv::Mat image = testing::make_texture(kSize, 8, 6, 1.5);
  const cv::Point2f center(480, 270);
  const double rotation_deg = 40.0;
  const cv::Mat rot = cv::getRotationMatrix2D(center, rotation_deg, 1.0);
  cv::Mat rotated;
  cv::warpAffine(image, rotated, rot, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  const OrbFeatures fa = extract_ok(extractor, image);
  const OrbFeatures fb = extract_ok(extractor, rotated);
  std::vector<int> distances;
  std::vector<double> angle_changes;
  corresponding(
      fa, fb,
      [&rot](cv::Point2f p) {
        return cv::Point2f(
            float(rot.at<double>(0, 0) * p.x + rot.at<double>(0, 1) * p.y + rot.at<double>(0, 2)),
            float(rot.at<double>(1, 0) * p.x + rot.at<double>(1, 1) * p.y + rot.at<double>(1, 2)));
      },
      1.0, &distances, &angle_changes);
  ASSERT_GT(distances.size(), 100u);
  int angle_ok = 0;
  for (const double change : angle_changes) {
    double delta = std::fmod(change + rotation_deg + 720.0, 360.0);
    if (delta > 180.0) delta -= 360.0;
    if (std::abs(delta) < 10.0) ++angle_ok;
  }
  EXPECT_GT(angle_ok, static_cast<int>(0.8 * angle_changes.size()));
  EXPECT_LT(median(distances), 50);
}

TEST(OrbExtractor, RejectsBadInputWithAReason) {
  OrbExtractor extractor(config::OrbConfig{});
  const cv::Mat image = testing::make_texture(kSize, 9);
  const auto color = extractor.extract(cv::Mat(kSize, CV_8UC3, cv::Scalar::all(0)));
  ASSERT_FALSE(color.has_value());
  EXPECT_EQ(color.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(color.error().message.find("CV_8UC1"), std::string::npos);
  const auto bad_mask = extractor.extract(image, cv::Mat::zeros(100, 100, CV_8UC1));
  ASSERT_FALSE(bad_mask.has_value());
  EXPECT_NE(bad_mask.error().message.find("mask"), std::string::npos);
  const auto tiny = extractor.extract(cv::Mat(20, 20, CV_8UC1, cv::Scalar(0)));
  ASSERT_FALSE(tiny.has_value());
}

TEST(OrbExtractor, ValidateNamesKeyValueAndRule) {
  config::OrbConfig cfg;
  EXPECT_TRUE(validate(cfg).has_value());
  cfg.scale_factor = 0.9;
  auto status = validate(cfg);
  ASSERT_FALSE(status.has_value());
  EXPECT_NE(status.error().message.find("orb.scale_factor = 0.9"), std::string::npos)
      << status.error().message;
  cfg = config::OrbConfig{};
  cfg.min_fast_threshold = 30;
  status = validate(cfg);
  ASSERT_FALSE(status.has_value());
  EXPECT_NE(status.error().message.find("orb.min_fast_threshold = 30"), std::string::npos);
  EXPECT_FALSE(OrbExtractor::create(cfg).has_value());
  cfg = config::OrbConfig{};
  cfg.strong_fast_threshold = -1;
  status = validate(cfg);
  ASSERT_FALSE(status.has_value());
  EXPECT_NE(status.error().message.find("orb.strong_fast_threshold = -1"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::features
