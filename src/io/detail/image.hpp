#pragma once
// Loading sequence images as 8-bit gray, with errors that name the frame.

#include <cstddef>
#include <string>

#include <opencv2/core.hpp>

#include "sitepose/core/channel_order.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::io::detail {

// Reads `path` (frame `frame_index`) as CV_8UC1: 8-bit gray is kept, 8-bit
// 3 / 4 channel images converted, their first channel taken as blue (kBgr)
// or red (kRgb). kNotFound when missing; kParseError when it cannot be
// decoded or is not 8-bit with 1, 3 or 4 channels.
Expected<cv::Mat> load_gray_image(const std::string& path, std::size_t frame_index, ChannelOrder order);

// "frame 12 (<path>): image is 64x48, expected 640x480 (<why>)" or ok.
Status check_image_size(const cv::Mat& image, int width, int height, const std::string& path,
                        std::size_t frame_index, const std::string& why);

// NNNNNN.png, six digits zero padded.
std::string frame_file_name(std::size_t frame_index);

}  // namespace sitepose::io::detail
