#include "sitepose/io/labels.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "sitepose/testing/files.hpp"

namespace sitepose::io {
namespace {

using testing::TempDir;

constexpr const char* kHeader = "frame,instance,class,x,y,w,h,moving\n";

TEST(BoxesCsv, ReadsRowsSortedWithMovingStates) {
  TempDir dir;
  const std::string path = dir.write("boxes.csv", std::string(kHeader) +
                                                      "1,7,truck,10,12,20,8,1\n"
                                                      "0,3,person,0,0,4,9,\n"
                                                      "0,2,roller,5.5,6.25,10,10,0\n\n");
  auto boxes = read_boxes_csv(path);
  ASSERT_TRUE(boxes) << boxes.error().message;
  ASSERT_EQ(boxes->size(), 3u);
  EXPECT_EQ((*boxes)[0].frame, 0);
  EXPECT_EQ((*boxes)[0].instance, 2);
  EXPECT_EQ((*boxes)[0].class_name, "roller");
  // Decimal box -> covering integer rect: x 5..15.5 -> [5, 16), y 6.25..16.25 -> [6, 17).
  EXPECT_EQ((*boxes)[0].box, cv::Rect(5, 6, 11, 11));
  EXPECT_EQ((*boxes)[0].moving, std::optional<bool>(false));
  EXPECT_EQ((*boxes)[1].instance, 3);
  EXPECT_FALSE((*boxes)[1].moving.has_value());
  EXPECT_EQ((*boxes)[2].frame, 1);
  EXPECT_EQ((*boxes)[2].box, cv::Rect(10, 12, 20, 8));
  EXPECT_EQ((*boxes)[2].moving, std::optional<bool>(true));
}

struct BadCase {
  std::string row;
  std::string expected;  // substring of the message after "boxes.csv:3: "
};

TEST(BoxesCsv, MalformedRowsNamedWithLine) {
  const std::vector<BadCase> cases = {
      {"0,1,truck,1,2,3", "expected 8 fields"},
      {"0,1,truck,1,2,3,4,5,6", "expected 8 fields"},
      {"x,1,truck,1,2,3,4,1", "field 'frame': expected an integer, got 'x'"},
      {"-1,1,truck,1,2,3,4,1", "field 'frame': expected >= 0"},
      {"0,0,truck,1,2,3,4,1", "field 'instance': expected 1..65535"},
      {"0,1.5,truck,1,2,3,4,1", "field 'instance': expected an integer"},
      {"0,1,,1,2,3,4,1", "field 'class': expected one word"},
      {"0,1,big truck,1,2,3,4,1", "field 'class': expected one word"},
      {"0,1,truck,a,2,3,4,1", "field 'x': expected a pixel coordinate"},
      {"0,1,truck,1,2,0,4,1", "fields 'w', 'h': expected > 0"},
      {"0,1,truck,1,2,3,nan,1", "field 'h': expected a pixel coordinate"},
      {"0,1,truck,1,2,3,4,yes", "field 'moving': expected 1, 0 or empty"},
      {"0,5,truck,1,2,3,4,1", "instance 5 appears twice in frame 0"},
  };
  for (const BadCase& c : cases) {
    TempDir dir;
    const std::string path =
        dir.write("boxes.csv", std::string(kHeader) + "0,5,cone,1,1,2,2,0\n" + c.row + "\n");
    auto boxes = read_boxes_csv(path);
    ASSERT_FALSE(boxes) << c.row;
    EXPECT_EQ(boxes.error().code, ErrorCode::kParseError);
    EXPECT_NE(boxes.error().message.find("boxes.csv:3: " + c.expected), std::string::npos)
        << "row '" << c.row << "' gave: " << boxes.error().message;
  }
}

// issue 20: instance 65536 passed here, became 0 (background) as a 16-bit
// mask value, and the machine was never masked.
TEST(BoxesCsv, InstanceIdsBeyond16BitsRejected) {
  TempDir dir;
  auto largest = read_boxes_csv(dir.write("ok.csv", std::string(kHeader) + "0,65535,truck,1,2,3,4,1\n"));
  ASSERT_TRUE(largest) << largest.error().message;
  EXPECT_EQ((*largest)[0].instance, 65535);
  auto wide = read_boxes_csv(dir.write("wide.csv", std::string(kHeader) + "0,65536,truck,1,2,3,4,1\n"));
  ASSERT_FALSE(wide);
  EXPECT_EQ(wide.error().code, ErrorCode::kParseError);
  EXPECT_NE(wide.error().message.find("wide.csv:2: field 'instance': expected 1..65535"), std::string::npos)
      << wide.error().message;
  EXPECT_NE(wide.error().message.find("got 65536"), std::string::npos);
}

TEST(BoxesCsv, WrongHeaderAndFrameRangeRejected) {
  TempDir dir;
  auto header = read_boxes_csv(dir.write("h.csv", "frame,instance,class,x,y,w,h\n0,1,a,1,1,1,1\n"));
  ASSERT_FALSE(header);
  EXPECT_NE(header.error().message.find("h.csv:1: expected the header"), std::string::npos);
  const std::string path = dir.write("r.csv", std::string(kHeader) + "0,1,cone,1,1,2,2,0\n2,1,cone,1,1,2,2,0\n");
  EXPECT_TRUE(read_boxes_csv(path, 3));
  auto range = read_boxes_csv(path, 2);
  ASSERT_FALSE(range);
  EXPECT_NE(range.error().message.find("r.csv:3: field 'frame': expected < 2"), std::string::npos)
      << range.error().message;
}

TEST(InstanceMask, Reads16BitAndRejects8Bit) {
  TempDir dir;
  cv::Mat mask16(48, 64, CV_16UC1, cv::Scalar(0));
  mask16(cv::Rect(10, 10, 5, 5)).setTo(1000);  // ids above 255 survive only in 16 bit
  ASSERT_TRUE(cv::imwrite(dir / "m16.png", mask16));
  auto good = read_instance_mask(dir / "m16.png");
  ASSERT_TRUE(good) << good.error().message;
  EXPECT_EQ(good->type(), CV_16UC1);
  EXPECT_EQ(good->at<std::uint16_t>(12, 12), 1000);
  EXPECT_EQ(good->at<std::uint16_t>(0, 0), 0);

  cv::Mat mask8(48, 64, CV_8UC1, cv::Scalar(3));
  ASSERT_TRUE(cv::imwrite(dir / "m8.png", mask8));
  auto bad = read_instance_mask(dir / "m8.png");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, ErrorCode::kParseError);
  EXPECT_NE(bad.error().message.find("m8.png: expected a 16-bit single-channel PNG"), std::string::npos)
      << bad.error().message;
  EXPECT_NE(bad.error().message.find("got 8-bit"), std::string::npos);

  auto missing = read_instance_mask(dir / "none.png");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace sitepose::io
