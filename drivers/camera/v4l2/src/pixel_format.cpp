#include "sitepose/drivers/v4l2/pixel_format.hpp"

#include <linux/videodev2.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>

namespace sitepose::drivers::v4l2 {

Expected<std::vector<PixelFormat>> parse_pixel_preference(const std::string& name) {
  if (name == "auto") return auto_preference();
  if (name == "GREY") return std::vector<PixelFormat>{PixelFormat::kGrey};
  if (name == "YUYV") return std::vector<PixelFormat>{PixelFormat::kYuyv};
  if (name == "MJPG") return std::vector<PixelFormat>{PixelFormat::kMjpeg};
  return make_error(ErrorCode::kInvalidArgument,
                    "pixel format \"" + name + "\" (expected one of: auto, GREY, YUYV, MJPG)");
}

const char* to_string(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGrey: return "GREY";
    case PixelFormat::kYuyv: return "YUYV";
    case PixelFormat::kMjpeg: return "MJPG";
  }
  return "?";
}

std::uint32_t fourcc(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGrey: return V4L2_PIX_FMT_GREY;
    case PixelFormat::kYuyv: return V4L2_PIX_FMT_YUYV;
    case PixelFormat::kMjpeg: return V4L2_PIX_FMT_MJPEG;
  }
  return 0;
}

bool from_fourcc(std::uint32_t code, PixelFormat& format) {
  for (PixelFormat f : {PixelFormat::kGrey, PixelFormat::kYuyv, PixelFormat::kMjpeg}) {
    if (fourcc(f) == code) {
      format = f;
      return true;
    }
  }
  return false;
}

std::string fourcc_text(std::uint32_t code) {
  std::string text;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((code >> (8 * i)) & 0xFF);
    if (c < 0x20 || c > 0x7E) {
      char hex[16];
      std::snprintf(hex, sizeof(hex), "0x%08x", code);
      return hex;
    }
    text += c;
  }
  return text;
}

const std::vector<PixelFormat>& auto_preference() {
  static const std::vector<PixelFormat> order{PixelFormat::kGrey, PixelFormat::kYuyv, PixelFormat::kMjpeg};
  return order;
}

Expected<cv::Mat> to_gray(PixelFormat format, const std::uint8_t* data, std::size_t bytes, int width,
                          int height, std::size_t bytes_per_line) {
  const std::string what = std::string(to_string(format)) + " " + std::to_string(width) + "x" +
                           std::to_string(height) + " frame of " + std::to_string(bytes) + " bytes";
  if (format == PixelFormat::kMjpeg) {
    const cv::Mat encoded(1, static_cast<int>(bytes), CV_8UC1, const_cast<std::uint8_t*>(data));
    cv::Mat gray;
    try {
      gray = cv::imdecode(encoded, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception&) {
      gray = cv::Mat();
    }
    if (gray.empty()) return make_error(ErrorCode::kIoError, what + ": JPEG does not decode");
    if (gray.cols != width || gray.rows != height) {
      return make_error(ErrorCode::kIoError, what + ": JPEG decodes to " + std::to_string(gray.cols) + "x" +
                                                 std::to_string(gray.rows));
    }
    return gray;
  }
  const std::size_t pixel_bytes = format == PixelFormat::kYuyv ? 2 : 1;
  const std::size_t row_bytes = static_cast<std::size_t>(width) * pixel_bytes;
  const std::size_t stride = bytes_per_line >= row_bytes ? bytes_per_line : row_bytes;
  if (height <= 0 || bytes < stride * static_cast<std::size_t>(height - 1) + row_bytes) {
    return make_error(ErrorCode::kIoError,
                      what + ": too short for " + std::to_string(stride) + " bytes per line");
  }
  cv::Mat gray(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = data + stride * static_cast<std::size_t>(y);
    std::uint8_t* out = gray.ptr<std::uint8_t>(y);
    if (pixel_bytes == 1) {
      std::copy(row, row + width, out);
    } else {
      for (int x = 0; x < width; ++x) out[x] = row[2 * x];  // Y0 U Y1 V: luma at even bytes
    }
  }
  return gray;
}

}  // namespace sitepose::drivers::v4l2
