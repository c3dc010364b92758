#include "detail/image.hpp"

#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace sitepose::io::detail {

Expected<cv::Mat> load_gray_image(const std::string& path, std::size_t frame_index, ChannelOrder order) {
  const std::string frame = "frame " + std::to_string(frame_index) + " (" + path + "): ";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, frame + "image file does not exist");
  }
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) return make_error(ErrorCode::kParseError, frame + "cannot decode the image");
  if (raw.depth() != CV_8U) {
    return make_error(ErrorCode::kParseError,
                      frame + "expected an 8-bit image, got depth code " + std::to_string(raw.depth()));
  }
  cv::Mat gray;
  switch (raw.channels()) {
    case 1: return raw;
    case 3:
      cv::cvtColor(raw, gray, order == ChannelOrder::kRgb ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
      return gray;
    case 4:
      cv::cvtColor(raw, gray, order == ChannelOrder::kRgb ? cv::COLOR_RGBA2GRAY : cv::COLOR_BGRA2GRAY);
      return gray;
    default:
      return make_error(ErrorCode::kParseError,
                        frame + "expected 1, 3 or 4 channels, got " + std::to_string(raw.channels()));
  }
}

Status check_image_size(const cv::Mat& image, int width, int height, const std::string& path,
                        std::size_t frame_index, const std::string& why) {
  if (image.cols == width && image.rows == height) return ok_status();
  return make_error(ErrorCode::kInvalidArgument,
                    "frame " + std::to_string(frame_index) + " (" + path + "): image is " +
                        std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", expected " +
                        std::to_string(width) + "x" + std::to_string(height) + " (" + why + ")");
}

std::string frame_file_name(std::size_t frame_index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu.png", frame_index);
  return name;
}

}  // namespace sitepose::io::detail
