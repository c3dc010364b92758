#include "sitepose/dynamic/masking.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace sitepose::dynamic {
namespace {

const cv::Size kImage(100, 50);

config::DynamicConfig default_config() {
  config::DynamicConfig c;
  c.dynamic_classes = {"truck", "roller"};
  c.tau_mar = 0.5;
  return c;
}

TEST(Masking, UnionRatioCountsOverlapOnceAndClips) {
  std::vector<ObjectBox> boxes{{1, "truck", 1.0, cv::Rect(0, 0, 50, 50)},
                               {2, "truck", 1.0, cv::Rect(25, 0, 50, 50)},
                               {3, "truck", 1.0, cv::Rect(90, 40, 50, 50)}};
  // 0..75 x 0..50 plus 90..100 x 40..50 = 3750 + 100.
  EXPECT_NEAR(box_union_ratio(boxes, kImage), 3850.0 / 5000.0, 1e-12);
}

TEST(Masking, SmallerBoxWinsWhereBoxesOverlap) {
  std::vector<ObjectBox> boxes{{7, "truck", 1.0, cv::Rect(10, 10, 10, 10)},
                               {3, "truck", 1.0, cv::Rect(0, 0, 60, 40)}};
  const cv::Mat labels = box_instance_labels(boxes, kImage);
  EXPECT_EQ(labels.at<std::uint16_t>(15, 15), 7);
  EXPECT_EQ(labels.at<std::uint16_t>(5, 5), 3);
  EXPECT_EQ(labels.at<std::uint16_t>(45, 95), 0);
}

struct CountingSegmenter {
  int calls = 0;
  cv::Mat mask;
  PixelSegmenter segmenter() {
    return [this](const std::vector<ObjectBox>&) -> Expected<cv::Mat> {
      ++calls;
      return mask;
    };
  }
};

TEST(Masking, HierarchicalSegmentsOnlyAtOrAboveTau) {
  CountingSegmenter seg;
  seg.mask = cv::Mat::zeros(kImage, CV_16UC1);
  seg.mask(cv::Rect(0, 0, 10, 10)).setTo(1);
  seg.mask(cv::Rect(50, 0, 10, 10)).setTo(9);  // not a detected dynamic box: ignored
  FrameObjects small{{{1, "truck", 1.0, cv::Rect(0, 0, 40, 50)}}, seg.segmenter()};  // mar 0.4
  auto r = build_mask(config::MaskingMode::kHierarchical, small, kImage, default_config());
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->pixel_mask_used);
  EXPECT_EQ(seg.calls, 0);
  EXPECT_NEAR(r->masked_ratio, 0.4, 1e-12);
  FrameObjects big{{{1, "truck", 1.0, cv::Rect(0, 0, 50, 50)}}, seg.segmenter()};  // mar 0.5
  r = build_mask(config::MaskingMode::kHierarchical, big, kImage, default_config());
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->pixel_mask_used);
  EXPECT_EQ(seg.calls, 1);
  EXPECT_NEAR(r->mar, 0.5, 1e-12);
  // The 10x10 segment grows by the 4 px dilation, the foreign id 9 is gone.
  EXPECT_GT(r->masked_ratio, 100.0 / 5000.0);
  EXPECT_LE(r->masked_ratio, 14.0 * 14.0 / 5000.0);
  EXPECT_EQ(r->instance_labels.at<std::uint16_t>(5, 55), 0);
  EXPECT_EQ(r->instance_labels.at<std::uint16_t>(5, 13), 1);
  EXPECT_EQ(r->instance_labels.at<std::uint16_t>(5, 15), 0);
}

TEST(Masking, TimesTheDetectorsSegmentationApart) {
  // The segmenter is the detector's work: its wall time is reported on its
  // own (segment_ms), zero when it is not called.
  FrameObjects objects{{{1, "truck", 1.0, cv::Rect(0, 0, 50, 50)}},
                       [](const std::vector<ObjectBox>&) -> Expected<cv::Mat> {
                         std::this_thread::sleep_for(std::chrono::milliseconds(20));
                         return cv::Mat(cv::Mat::zeros(kImage, CV_16UC1));
                       }};
  auto r = build_mask(config::MaskingMode::kPixel, objects, kImage, default_config());
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->pixel_mask_used);
  EXPECT_GE(r->segment_ms, 20.0);
  r = build_mask(config::MaskingMode::kBbox, objects, kImage, default_config());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->segment_ms, 0.0);
}

TEST(Masking, NonDynamicClassesAreNotMaskedAndBboxNeverSegments) {
  CountingSegmenter seg;
  seg.mask = cv::Mat::zeros(kImage, CV_16UC1);
  FrameObjects objects{
      {{1, "cone", 1.0, cv::Rect(0, 0, 100, 50)}, {2, "roller", 1.0, cv::Rect(0, 0, 80, 50)}},
      seg.segmenter()};
  auto r = build_mask(config::MaskingMode::kBbox, objects, kImage, default_config());
  ASSERT_TRUE(r);
  EXPECT_EQ(seg.calls, 0);
  EXPECT_NEAR(r->mar, 0.8, 1e-12);
  ASSERT_EQ(r->dynamic_boxes.size(), 1u);
  EXPECT_EQ(r->dynamic_boxes[0].instance, 2);
  EXPECT_EQ(r->instance_labels.at<std::uint16_t>(10, 90), 0);
}

TEST(Masking, ModeNoneReportsMarWithoutMask) {
  FrameObjects objects{{{1, "truck", 1.0, cv::Rect(0, 0, 30, 50)}}, {}};
  auto r = build_mask(config::MaskingMode::kNone, objects, kImage, default_config());
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->instance_labels.empty());
  EXPECT_NEAR(r->mar, 0.3, 1e-12);
}

TEST(Masking, PixelModeWithoutSegmenterIsUnsupported) {
  FrameObjects objects{{{1, "truck", 1.0, cv::Rect(0, 0, 30, 50)}}, {}};
  auto r = build_mask(config::MaskingMode::kPixel, objects, kImage, default_config());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
}

TEST(Masking, WrongSegmentationSizeIsAnError) {
  FrameObjects objects{{{1, "truck", 1.0, cv::Rect(0, 0, 30, 50)}},
                       [](const std::vector<ObjectBox>&) -> Expected<cv::Mat> {
                         return cv::Mat(cv::Size(10, 10), CV_16UC1, cv::Scalar(0));
                       }};
  auto r = build_mask(config::MaskingMode::kPixel, objects, kImage, default_config());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace sitepose::dynamic
