#pragma once
// Camera pixel formats the stereo source accepts, and their conversion to
// the pipeline's 8-bit gray. Pure functions, thread-compatible.

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "sitepose/core/expected.hpp"

namespace sitepose::drivers::aravis {

// GenICam PFNC names: Mono8, Mono16, BayerRG8, BayerGR8, BayerGB8, BayerBG8
// (the Bayer name gives the colours of the first row's first two pixels).
enum class PixelFormat { kMono8, kMono16, kBayerRG8, kBayerGR8, kBayerGB8, kBayerBG8 };

// Errors list the accepted names.
Expected<PixelFormat> parse_pixel_format(const std::string& name);
const char* to_string(PixelFormat format);
int bytes_per_pixel(PixelFormat format);

// One image as a camera buffer holds it: rows packed without padding
// (GigE Vision and the fake camera), Mono16 little-endian.
struct RawImage {
  const std::uint8_t* data = nullptr;
  std::size_t size_bytes = 0;
  int width = 0;
  int height = 0;
  PixelFormat format = PixelFormat::kMono8;
};

// A new CV_8UC1 image (never a view of `raw`, whose buffer goes back to the
// camera): Mono8 copied, Mono16 scaled by 1/256 and rounded (PFNC Mono16
// spans the full 16 bits), Bayer demosaiced to luminance. kInvalidArgument when the
// buffer is smaller than width x height x bytes per pixel.
Expected<cv::Mat> to_gray8(const RawImage& raw);

}  // namespace sitepose::drivers::aravis
