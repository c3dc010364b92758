#include "sitepose/drivers/aravis/pixel_convert.hpp"

#include <array>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace sitepose::drivers::aravis {
namespace {

constexpr std::array<std::pair<PixelFormat, const char*>, 6> kNames{{
    {PixelFormat::kMono8, "Mono8"},
    {PixelFormat::kMono16, "Mono16"},
    {PixelFormat::kBayerRG8, "BayerRG8"},
    {PixelFormat::kBayerGR8, "BayerGR8"},
    {PixelFormat::kBayerGB8, "BayerGB8"},
    {PixelFormat::kBayerBG8, "BayerBG8"},
}};

// OpenCV names a Bayer pattern by the second row's second and third pixels,
// PFNC by the first row's first two: PFNC RG is OpenCV's BG, and so on.
int bayer_to_gray_code(PixelFormat format) {
  switch (format) {
    case PixelFormat::kBayerRG8:
      return cv::COLOR_BayerBG2GRAY;
    case PixelFormat::kBayerGR8:
      return cv::COLOR_BayerGB2GRAY;
    case PixelFormat::kBayerGB8:
      return cv::COLOR_BayerGR2GRAY;
    case PixelFormat::kBayerBG8:
      return cv::COLOR_BayerRG2GRAY;
    default:
      return -1;
  }
}

}  // namespace

Expected<PixelFormat> parse_pixel_format(const std::string& name) {
  std::string accepted;
  for (const auto& [format, text] : kNames) {
    if (name == text) return format;
    accepted += accepted.empty() ? text : std::string(", ") + text;
  }
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown pixel format \"" + name + "\" (expected one of: " + accepted + ")");
}

const char* to_string(PixelFormat format) {
  for (const auto& [f, text] : kNames) {
    if (f == format) return text;
  }
  return "?";
}

int bytes_per_pixel(PixelFormat format) { return format == PixelFormat::kMono16 ? 2 : 1; }

Expected<cv::Mat> to_gray8(const RawImage& raw) {
  if (raw.width <= 0 || raw.height <= 0 || raw.data == nullptr) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "image " + std::to_string(raw.width) + "x" + std::to_string(raw.height) + ": empty or without data");
  }
  const std::size_t need = static_cast<std::size_t>(raw.width) * static_cast<std::size_t>(raw.height) *
                           static_cast<std::size_t>(bytes_per_pixel(raw.format));
  if (raw.size_bytes < need) {
    return make_error(ErrorCode::kInvalidArgument,
                      std::string(to_string(raw.format)) + " image " + std::to_string(raw.width) + "x" +
                          std::to_string(raw.height) + ": buffer holds " + std::to_string(raw.size_bytes) +
                          " bytes, expected " + std::to_string(need));
  }
  // OpenCV takes a non-const pointer for a header; the input is only read.
  void* data = const_cast<std::uint8_t*>(raw.data);
  cv::Mat gray;
  if (raw.format == PixelFormat::kMono8) {
    cv::Mat(raw.height, raw.width, CV_8UC1, data).copyTo(gray);
  } else if (raw.format == PixelFormat::kMono16) {
    cv::Mat(raw.height, raw.width, CV_16UC1, data).convertTo(gray, CV_8U, 1.0 / 256.0);
  } else {
    cv::cvtColor(cv::Mat(raw.height, raw.width, CV_8UC1, data), gray, bayer_to_gray_code(raw.format));
  }
  return gray;
}

}  // namespace sitepose::drivers::aravis
