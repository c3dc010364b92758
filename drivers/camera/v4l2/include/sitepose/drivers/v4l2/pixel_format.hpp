#pragma once
// The pixel formats the V4L2 source takes and their conversion to 8-bit
// gray: GREY (copied), YUYV 4:2:2 (its luma bytes), MJPEG (cv::imdecode,
// gray). Pure functions; no device.

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::drivers::v4l2 {

enum class PixelFormat { kGrey, kYuyv, kMjpeg };

// "GREY" | "YUYV" | "MJPG"; "auto" gives nullopt (negotiate). Errors list the
// accepted names.
Expected<std::vector<PixelFormat>> parse_pixel_preference(const std::string& name);
const char* to_string(PixelFormat format);
std::uint32_t fourcc(PixelFormat format);
// nullopt-like: false when the fourcc is none of the three.
bool from_fourcc(std::uint32_t code, PixelFormat& format);
// "YUYV" from a fourcc, for messages ("\x01..." shown as hex).
std::string fourcc_text(std::uint32_t code);

// Negotiation order when the format is "auto": uncompressed gray first, then
// YUYV (luma is exact), MJPEG last (block artefacts make features jitter).
const std::vector<PixelFormat>& auto_preference();

// One image of `format` in `data` (`bytes` long, rows `bytes_per_line` apart
// for the raw formats) -> a new CV_8UC1 width x height image. Fails when the
// buffer is too short or the JPEG does not decode to that size.
Expected<cv::Mat> to_gray(PixelFormat format, const std::uint8_t* data, std::size_t bytes, int width,
                          int height, std::size_t bytes_per_line);

}  // namespace sitepose::drivers::v4l2
