#include "sitepose/detect/plugin_loader.hpp"

#include "sitepose/detect/isolated_detector.hpp"

#include <fstream>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sitepose::detect {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Every loader guarantee holds for a plugin in this process and for one in
// sitepose-detector-host (the same validation, the loader's own messages).
class PluginLoader : public ::testing::TestWithParam<bool> {
 protected:
  static Expected<std::unique_ptr<Detector>> load(const std::string& path, const std::string& yaml,
                                                  const PluginLoadOptions& options = {}) {
    if (!GetParam()) return load_detector_plugin(path, yaml, options);
    IsolationOptions isolation;
    isolation.in_child_process = true;
    return load_isolated_plugin(path, yaml, options, isolation);
  }
};

INSTANTIATE_TEST_SUITE_P(Detector, PluginLoader, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? "InHostProcess" : "InProcess";
                         });

TEST_P(PluginLoader, MissingFileIsNotFoundNamingThePath) {
  auto d = load("/nonexistent/libnothing.so", "");
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code, ErrorCode::kNotFound);
  EXPECT_TRUE(contains(d.error().message, "/nonexistent/libnothing.so")) << d.error().message;
}

TEST_P(PluginLoader, FileThatIsNotALibraryIsRefused) {
  const testing::TempDir dir;
  const std::string path = dir / "fake.so";
  std::ofstream(path) << "this is not an ELF file\n";
  auto d = load(path, "");
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code, ErrorCode::kUnsupported);
  EXPECT_TRUE(contains(d.error().message, path)) << d.error().message;
  EXPECT_TRUE(contains(d.error().message, "cannot be loaded")) << d.error().message;
}

TEST_P(PluginLoader, LibraryWithoutTheAbiNamesTheMissingSymbols) {
  auto d = load(DETECT_TEST_MISSING_SYMBOL_PLUGIN, "");
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code, ErrorCode::kUnsupported);
  const std::string& m = d.error().message;
  EXPECT_TRUE(contains(m, "not a sitepose detector plugin")) << m;
  EXPECT_TRUE(contains(m, "sitepose_detector_detect")) << m;
  EXPECT_TRUE(contains(m, "sitepose_detector_segment")) << m;
  EXPECT_TRUE(contains(m, "sitepose_detector_destroy")) << m;
  EXPECT_FALSE(contains(m, "sitepose_detector_create")) << m;
}

TEST_P(PluginLoader, WrongAbiVersionIsRefusedNamingBothVersions) {
  auto d = load(DETECT_TEST_WRONG_ABI_PLUGIN, "");
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code, ErrorCode::kUnsupported);
  EXPECT_TRUE(contains(d.error().message, "ABI version 99")) << d.error().message;
  EXPECT_TRUE(contains(d.error().message, "expects 1")) << d.error().message;
  EXPECT_TRUE(contains(d.error().message, DETECT_TEST_WRONG_ABI_PLUGIN)) << d.error().message;
}

TEST_P(PluginLoader, CreateFailureQuotesThePlugin) {
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: create_fail");
  ASSERT_FALSE(d);
  EXPECT_TRUE(contains(d.error().message, "garbage plugin refuses to start")) << d.error().message;
}

TEST_P(PluginLoader, CapacityBelowOneIsRefused) {
  PluginLoadOptions options;
  options.capacity = 0;
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: garbage", options);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code, ErrorCode::kInvalidArgument);
}

TEST_P(PluginLoader, GarbageDetectionsAreDroppedAndCounted) {
  PluginLoadOptions options;
  options.name = "garbage";
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: garbage", options);
  ASSERT_TRUE(d) << d.error().message;
  Detector& detector = **d;
  EXPECT_EQ(detector.name(), "garbage");
  EXPECT_TRUE(detector.capabilities().has_segmentation);
  EXPECT_FALSE(detector.capabilities().tracks_ids);

  const StereoFrame frame = test::gray_frame(64, 48);
  auto dets = detector.detect(frame);
  ASSERT_TRUE(dets) << dets.error().message;
  ASSERT_EQ(dets->size(), 2u);
  EXPECT_EQ((*dets)[0].class_name, "truck");
  EXPECT_EQ((*dets)[0].instance, 1);
  EXPECT_EQ((*dets)[0].box, cv::Rect(10, 10, 20, 20));
  EXPECT_NEAR((*dets)[0].score, 0.9, 1e-6);
  // Partly outside the image: clipped, kept.
  EXPECT_EQ((*dets)[1].class_name, "roller");
  EXPECT_EQ((*dets)[1].box, cv::Rect(54, 38, 10, 10));
  const DetectorHealth h = detector.health();
  EXPECT_EQ(h.frames, 1);
  EXPECT_EQ(h.detections, 2);
  // NaN, negative, infinite score, outside, zero width, instance 0,
  // duplicate id, unterminated name, overflowing box, empty name.
  EXPECT_EQ(h.dropped_detections, 10);
  EXPECT_EQ(h.failed_calls, 0);

  // A second frame counts again: dropping is per frame, nothing sticks.
  ASSERT_TRUE(detector.detect(frame));
  EXPECT_EQ(detector.health().dropped_detections, 20);
  EXPECT_EQ(detector.health().frames, 2);
}

TEST_P(PluginLoader, ScoreThresholdFiltersWithoutCountingAsGarbage) {
  PluginLoadOptions options;
  options.min_score = 0.8;
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: garbage", options);
  ASSERT_TRUE(d) << d.error().message;
  auto dets = (*d)->detect(test::gray_frame(64, 48));
  ASSERT_TRUE(dets);
  ASSERT_EQ(dets->size(), 1u);  // the 0.7 roller is below the threshold
  EXPECT_EQ((*d)->health().dropped_detections, 10);
}

TEST_P(PluginLoader, CountBeyondCapacityIsDroppedAndCounted) {
  PluginLoadOptions options;
  options.capacity = 4;
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: overflow", options);
  ASSERT_TRUE(d) << d.error().message;
  auto dets = (*d)->detect(test::gray_frame(64, 48));
  ASSERT_TRUE(dets) << dets.error().message;
  EXPECT_EQ(dets->size(), 1u);  // of the first 4 only the first is valid
  EXPECT_EQ((*d)->health().dropped_detections, 3 + 7);
}

TEST_P(PluginLoader, FailedCallsReturnErrorsAndCount) {
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: fail");
  ASSERT_TRUE(d) << d.error().message;
  const StereoFrame frame = test::gray_frame(64, 48, 17);
  auto dets = (*d)->detect(frame);
  ASSERT_FALSE(dets);
  EXPECT_EQ(dets.error().code, ErrorCode::kRuntime);
  EXPECT_TRUE(contains(dets.error().message, "frame 17")) << dets.error().message;
  EXPECT_TRUE(contains(dets.error().message, "simulated failure")) << dets.error().message;
  auto mask = (*d)->segment(frame, {});
  ASSERT_FALSE(mask);
  EXPECT_TRUE(contains(mask.error().message, "simulated segment failure")) << mask.error().message;
  EXPECT_EQ((*d)->health().failed_calls, 2);
}

TEST_P(PluginLoader, NegativeCountIsAFailedCall) {
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: negative_count");
  ASSERT_TRUE(d) << d.error().message;
  auto dets = (*d)->detect(test::gray_frame(64, 48));
  ASSERT_FALSE(dets);
  EXPECT_TRUE(contains(dets.error().message, "negative count")) << dets.error().message;
  EXPECT_EQ((*d)->health().failed_calls, 1);
}

TEST_P(PluginLoader, MaskPixelsOutsideTheirBoxAreCleared) {
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: garbage");
  ASSERT_TRUE(d) << d.error().message;
  const StereoFrame frame = test::gray_frame(64, 48);
  auto dets = (*d)->detect(frame);
  ASSERT_TRUE(dets);
  auto mask = (*d)->segment(frame, *dets);
  ASSERT_TRUE(mask) << mask.error().message;
  ASSERT_EQ(mask->type(), CV_16UC1);
  ASSERT_EQ(mask->size(), frame.left.size());
  // The plugin painted id 1 everywhere (and id 77 on two rows): only the
  // pixels of detection 1's box survive.
  EXPECT_EQ(cv::countNonZero(*mask), 20 * 20);
  EXPECT_EQ(cv::countNonZero((*mask)(cv::Rect(10, 10, 20, 20)) == 1), 20 * 20);
  EXPECT_EQ((*d)->health().cleared_mask_pixels, 64 * 48 - 20 * 20);
  EXPECT_EQ((*d)->health().segment_calls, 1);
}

TEST_P(PluginLoader, FramesTheAbiCannotCarryAreRejected) {
  auto d = load(DETECT_TEST_GARBAGE_PLUGIN, "mode: garbage");
  ASSERT_TRUE(d) << d.error().message;
  StereoFrame color = test::gray_frame(64, 48);
  color.left = cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(0));
  auto dets = (*d)->detect(color);
  ASSERT_FALSE(dets);
  EXPECT_EQ(dets.error().code, ErrorCode::kInvalidArgument);
  StereoFrame empty;
  EXPECT_FALSE((*d)->detect(empty));
  StereoFrame mismatched = test::gray_frame(64, 48);
  mismatched.right = cv::Mat(40, 64, CV_8UC1, cv::Scalar(0));
  EXPECT_FALSE((*d)->detect(mismatched));
  EXPECT_EQ((*d)->health().frames, 0);
}

}  // namespace
}  // namespace sitepose::detect
