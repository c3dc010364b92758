#include "sitepose/drivers/v4l2/pixel_format.hpp"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include "sitepose/testing/fake_v4l2.hpp"
#include "sitepose/testing/images.hpp"

namespace sitepose::drivers::v4l2 {
namespace {

TEST(PixelFormat, YuyvGivesItsLumaAndHonoursTheLineStride) {
  const cv::Mat gray = sitepose::testing::make_texture({8, 3}, 7, 1, 0.0);
  std::vector<std::uint8_t> bytes;
  const std::size_t stride = 8 * 2 + 4;  // padded lines
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 8; ++x) {
      bytes.push_back(gray.at<std::uint8_t>(y, x));
      bytes.push_back(static_cast<std::uint8_t>(x % 2 == 0 ? 90 : 170));  // U / V
    }
    bytes.insert(bytes.end(), 4, 0xEE);
  }
  auto out = to_gray(PixelFormat::kYuyv, bytes.data(), bytes.size(), 8, 3, stride);
  ASSERT_TRUE(out) << out.error().message;
  EXPECT_EQ(cv::norm(*out, gray, cv::NORM_INF), 0.0);
}

TEST(PixelFormat, GreyIsCopiedAndMjpegDecodedToGray) {
  const cv::Mat gray = sitepose::testing::make_texture({64, 48}, 3, 8, 1.0);
  const auto grey_bytes = testing::encode_frame(gray, V4L2_PIX_FMT_GREY);
  auto grey = to_gray(PixelFormat::kGrey, grey_bytes.data(), grey_bytes.size(), 64, 48, 64);
  ASSERT_TRUE(grey);
  EXPECT_EQ(cv::norm(*grey, gray, cv::NORM_INF), 0.0);
  EXPECT_NE(grey->data, grey_bytes.data()) << "a copy, not a view of the driver's buffer";
  const auto jpeg = testing::encode_frame(gray, V4L2_PIX_FMT_MJPEG);
  auto decoded = to_gray(PixelFormat::kMjpeg, jpeg.data(), jpeg.size(), 64, 48, 0);
  ASSERT_TRUE(decoded) << decoded.error().message;
  EXPECT_LT(cv::norm(*decoded, gray, cv::NORM_L1) / gray.total(), 3.0);
}

TEST(PixelFormat, ShortOrBrokenFramesAreErrors) {
  std::vector<std::uint8_t> bytes(100, 0);
  auto short_grey = to_gray(PixelFormat::kGrey, bytes.data(), bytes.size(), 64, 48, 64);
  ASSERT_FALSE(short_grey);
  EXPECT_NE(short_grey.error().message.find("too short"), std::string::npos);
  auto bad_jpeg = to_gray(PixelFormat::kMjpeg, bytes.data(), bytes.size(), 64, 48, 0);
  ASSERT_FALSE(bad_jpeg);
  EXPECT_NE(bad_jpeg.error().message.find("does not decode"), std::string::npos);
  const auto jpeg = testing::encode_frame(cv::Mat(32, 32, CV_8UC1, cv::Scalar(9)), V4L2_PIX_FMT_MJPEG);
  auto wrong_size = to_gray(PixelFormat::kMjpeg, jpeg.data(), jpeg.size(), 64, 48, 0);
  ASSERT_FALSE(wrong_size);
  EXPECT_NE(wrong_size.error().message.find("decodes to 32x32"), std::string::npos);
}

TEST(PixelFormat, ParsesPreferencesAndNamesFourccs) {
  EXPECT_EQ(parse_pixel_preference("auto")->size(), 3u);
  EXPECT_EQ(parse_pixel_preference("MJPG")->front(), PixelFormat::kMjpeg);
  auto bad = parse_pixel_preference("NV12");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("auto, GREY, YUYV, MJPG"), std::string::npos);
  EXPECT_EQ(fourcc_text(V4L2_PIX_FMT_YUYV), "YUYV");
  EXPECT_EQ(fourcc_text(0x01020304), "0x01020304");
}

}  // namespace
}  // namespace sitepose::drivers::v4l2
