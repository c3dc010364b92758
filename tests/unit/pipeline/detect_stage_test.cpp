// The daemon's detect stage (DetectorStage): detections reach the packet,
// pixel masks are made exactly when Algorithm 1 wants them (mode and mar),
// only for dynamic-class boxes, and a failing detector is an error with the
// frame marked undetected.

#include <gtest/gtest.h>

#include "sitepose/pipeline/detect_stage.hpp"

namespace sitepose::pipeline {
namespace {

constexpr int kWidth = 100;
constexpr int kHeight = 50;

// Answers with fixed detections; segment() paints each asked box.
class FakeDetector final : public detect::Detector {
 public:
  FakeDetector(std::vector<detect::Detection> detections, bool can_segment, int* segment_calls,
               std::vector<std::uint16_t>* segmented)
      : detections_(std::move(detections)), can_segment_(can_segment), segment_calls_(segment_calls),
        segmented_(segmented) {}
  const std::string& name() const override { return name_; }
  detect::DetectorCapabilities capabilities() const override { return {can_segment_, true}; }
  Expected<std::vector<detect::Detection>> detect(const StereoFrame&) override {
    if (fail_) return make_error(ErrorCode::kRuntime, "fake detector failed");
    return detections_;
  }
  Expected<cv::Mat> segment(const StereoFrame& frame, const std::vector<detect::Detection>& wanted) override {
    ++*segment_calls_;
    cv::Mat mask = cv::Mat::zeros(frame.left.size(), CV_16UC1);
    for (const auto& d : wanted) {
      segmented_->push_back(d.instance);
      mask(d.box).setTo(d.instance);
    }
    return mask;
  }
  detect::DetectorHealth health() const override { return {}; }
  bool fail_ = false;

 private:
  std::string name_ = "fake";
  std::vector<detect::Detection> detections_;
  bool can_segment_;
  int* segment_calls_;
  std::vector<std::uint16_t>* segmented_;
};

FramePacket frame_packet() {
  FramePacket p;
  p.frame.left = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  p.frame.right = p.frame.left.clone();
  return p;
}

// A truck over `truck_width` columns and a cone (not an a-priori dynamic class).
std::vector<detect::Detection> truck_and_cone(int truck_width) {
  return {{"truck", 0.9, cv::Rect(0, 0, truck_width, kHeight), 3}, {"cone", 0.8, cv::Rect(90, 40, 5, 5), 7}};
}

struct StageRun {
  FramePacket packet;
  Status status;
  int segment_calls = 0;
  std::vector<std::uint16_t> segmented;
};

StageRun run_stage(config::MaskingMode mode, int truck_width, bool can_segment = true, bool fail = false) {
  StageRun r;
  config::DynamicConfig dynamic;
  dynamic.mode = mode;
  auto detector = std::make_unique<FakeDetector>(truck_and_cone(truck_width), can_segment, &r.segment_calls,
                                                 &r.segmented);
  detector->fail_ = fail;
  DetectorStage stage(std::move(detector), dynamic);
  r.packet = frame_packet();
  r.status = stage.annotate(r.packet);
  return r;
}

TEST(DetectorStage, BoxesReachThePacketAndSmallMarNeedsNoPixelMask) {
  const StageRun r = run_stage(config::MaskingMode::kFull, 40);  // mar 0.4 < tau 0.5
  ASSERT_TRUE(r.status) << r.status.error().message;
  EXPECT_TRUE(r.packet.detected);
  ASSERT_EQ(r.packet.objects.size(), 2u);
  EXPECT_EQ(r.packet.objects[0].class_name, "truck");
  EXPECT_EQ(r.packet.objects[0].instance, 3);
  EXPECT_EQ(r.packet.objects[1].class_name, "cone");
  EXPECT_EQ(r.segment_calls, 0);
  EXPECT_TRUE(r.packet.instance_mask.empty());
}

TEST(DetectorStage, LargeMarSegmentsOnlyTheDynamicClasses) {
  for (auto mode : {config::MaskingMode::kFull, config::MaskingMode::kHierarchical}) {
    const StageRun r = run_stage(mode, 60);  // mar 0.6 >= tau 0.5
    ASSERT_TRUE(r.status) << r.status.error().message;
    EXPECT_EQ(r.segment_calls, 1);
    EXPECT_EQ(r.segmented, std::vector<std::uint16_t>{3});
    ASSERT_FALSE(r.packet.instance_mask.empty());
    EXPECT_EQ(r.packet.instance_mask.at<std::uint16_t>(10, 10), 3);
    EXPECT_EQ(r.packet.instance_mask.at<std::uint16_t>(42, 92), 0);  // the cone stays unmasked
  }
}

TEST(DetectorStage, PixelModeAlwaysSegmentsAndBboxModeNever) {
  EXPECT_EQ(run_stage(config::MaskingMode::kPixel, 10).segment_calls, 1);
  EXPECT_EQ(run_stage(config::MaskingMode::kBbox, 90).segment_calls, 0);
}

TEST(DetectorStage, DetectorWithoutSegmentationLeavesTheMaskEmpty) {
  const StageRun r = run_stage(config::MaskingMode::kFull, 60, /*can_segment=*/false);
  ASSERT_TRUE(r.status);
  EXPECT_TRUE(r.packet.detected);
  EXPECT_EQ(r.segment_calls, 0);
  EXPECT_TRUE(r.packet.instance_mask.empty());
}

TEST(DetectorStage, FailingDetectorIsAnErrorAndTheFrameIsUndetected) {
  const StageRun r = run_stage(config::MaskingMode::kFull, 60, true, /*fail=*/true);
  ASSERT_FALSE(r.status);
  EXPECT_NE(r.status.error().message.find("fake detector failed"), std::string::npos);
  EXPECT_FALSE(r.packet.detected);
  EXPECT_TRUE(r.packet.objects.empty());
}

TEST(MakeDetectHook, ModeNonePassesThroughAndDetectorErrorsComeBack) {
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  auto hook = make_detect_hook(config, {});
  ASSERT_TRUE(hook) << hook.error().message;
  EXPECT_EQ((*hook)->name(), "pass-through");
  // labels without a sequence to read: create_detector's error, unchanged.
  config.dynamic.mode = config::MaskingMode::kFull;
  config.detector.name = "labels";
  auto failed = make_detect_hook(config, {});
  ASSERT_FALSE(failed);
  EXPECT_NE(failed.error().message.find("sequence"), std::string::npos) << failed.error().message;
}

}  // namespace
}  // namespace sitepose::pipeline
