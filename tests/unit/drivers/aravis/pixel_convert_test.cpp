#include "sitepose/drivers/aravis/pixel_convert.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

namespace sitepose::drivers::aravis {
namespace {

TEST(PixelConvert, ParsesPfncNamesAndListsThemOnError) {
  EXPECT_EQ(*parse_pixel_format("Mono16"), PixelFormat::kMono16);
  EXPECT_EQ(*parse_pixel_format("BayerGB8"), PixelFormat::kBayerGB8);
  const auto bad = parse_pixel_format("RGB8");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("Mono8, Mono16, BayerRG8"), std::string::npos) << bad.error().message;
  EXPECT_STREQ(to_string(PixelFormat::kBayerBG8), "BayerBG8");
}

TEST(PixelConvert, Mono8IsCopiedNotShared) {
  std::vector<std::uint8_t> pixels(6 * 4);
  for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<std::uint8_t>(i * 7);
  const auto gray = to_gray8({pixels.data(), pixels.size(), 6, 4, PixelFormat::kMono8});
  ASSERT_TRUE(gray) << gray.error().message;
  ASSERT_EQ(gray->type(), CV_8UC1);
  EXPECT_EQ(gray->at<std::uint8_t>(3, 5), pixels[3 * 6 + 5]);
  pixels[0] = 99;  // the buffer goes back to the camera
  EXPECT_EQ(gray->at<std::uint8_t>(0, 0), 0);
}

TEST(PixelConvert, Mono16ScalesTheFullRangeToEightBits) {
  const std::vector<std::uint16_t> values{0, 255, 256, 0x8000, 0xFF00, 0xFFFF};
  std::vector<std::uint8_t> bytes(values.size() * 2);
  std::memcpy(bytes.data(), values.data(), bytes.size());
  const auto gray = to_gray8({bytes.data(), bytes.size(), 3, 2, PixelFormat::kMono16});
  ASSERT_TRUE(gray) << gray.error().message;
  EXPECT_EQ(gray->at<std::uint8_t>(0, 0), 0);
  EXPECT_EQ(gray->at<std::uint8_t>(0, 1), 1);  // 255 / 256 rounds up
  EXPECT_EQ(gray->at<std::uint8_t>(0, 2), 1);
  EXPECT_EQ(gray->at<std::uint8_t>(1, 0), 128);
  EXPECT_EQ(gray->at<std::uint8_t>(1, 1), 255);
  EXPECT_EQ(gray->at<std::uint8_t>(1, 2), 255);
}

// A uniform colour mosaicked with the PFNC pattern named `format` (first
// row's first two pixels) must come back as its luminance: a wrong OpenCV
// code swaps red and blue and misses by far more than the tolerance.
void expect_bayer_luminance(PixelFormat format, const char* first_two_rows) {
  const int r = 200, g = 100, b = 20;
  const int w = 16, h = 12;
  std::vector<std::uint8_t> mosaic(static_cast<std::size_t>(w * h));
  auto value = [&](char c) { return c == 'R' ? r : c == 'G' ? g : b; };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      mosaic[static_cast<std::size_t>(y * w + x)] =
          static_cast<std::uint8_t>(value(first_two_rows[(y % 2) * 2 + (x % 2)]));
    }
  }
  const auto gray = to_gray8({mosaic.data(), mosaic.size(), w, h, format});
  ASSERT_TRUE(gray) << gray.error().message;
  const double expected = 0.299 * r + 0.587 * g + 0.114 * b;  // 121.8
  EXPECT_NEAR(gray->at<std::uint8_t>(h / 2, w / 2), expected, 3.0) << to_string(format);
}

TEST(PixelConvert, BayerPatternsFollowPfncNaming) {
  expect_bayer_luminance(PixelFormat::kBayerRG8, "RGGB");
  expect_bayer_luminance(PixelFormat::kBayerGR8, "GRBG");
  expect_bayer_luminance(PixelFormat::kBayerGB8, "GBRG");
  expect_bayer_luminance(PixelFormat::kBayerBG8, "BGGR");
}

TEST(PixelConvert, ShortBufferIsAnErrorNamingTheSizes) {
  std::vector<std::uint8_t> bytes(10);
  const auto gray = to_gray8({bytes.data(), bytes.size(), 4, 2, PixelFormat::kMono16});
  ASSERT_FALSE(gray);
  EXPECT_EQ(gray.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(gray.error().message.find("holds 10 bytes, expected 16"), std::string::npos)
      << gray.error().message;
}

}  // namespace
}  // namespace sitepose::drivers::aravis
