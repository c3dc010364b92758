#pragma once
// Object labels of a sitepose sequence (FORMATS.md): labels/boxes.csv and
// labels/masks/NNNNNN.png. Pixel coordinates are in the LEFT image.
// Pure functions, no shared state: safe to call from any thread.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"

namespace sitepose::io {

struct LabelBox {
  int frame = 0;      // index into times.txt
  int instance = 0;   // 1..65535, stable across frames; equals the mask pixel value
  std::string class_name;  // one word: truck, roller, excavator, person, cone, ...
  cv::Rect box;       // left-image pixels
  std::optional<bool> moving;  // 1 / 0 in the file; empty field = unknown
};

// Reads boxes.csv: header exactly "frame,instance,class,x,y,w,h,moving", then
// one row per object and frame. x, y, w, h may be integers or decimals; a
// decimal box becomes the smallest cv::Rect covering it (floor of x, y, ceil
// of x + w, y + h). Rows are returned sorted by (frame, instance).
// Errors (kParseError) name the file, the line and what was expected:
// wrong field count, non-numbers, frame < 0, instance outside 1..65535
// (a 16-bit mask pixel value), empty or
// non-word class, w or h <= 0, moving not in {1, 0, empty}, a repeated
// (frame, instance) pair, and frame >= n_frames when n_frames is given.
Expected<std::vector<LabelBox>> read_boxes_csv(const std::string& path,
                                               std::optional<std::size_t> n_frames = std::nullopt);

// Reads one instance mask: a 16-bit single-channel PNG (CV_16UC1), pixel =
// instance id, 0 = background. kNotFound when the file is missing,
// kParseError when it is not 16-bit single-channel (an 8-bit PNG would
// silently cap ids at 255).
Expected<cv::Mat> read_instance_mask(const std::string& path);

// The same check from the PNG header alone (no decoding), plus the size:
// a 16-bit gray PNG of width x height. For checking every mask at open.
// kNotFound when missing, kParseError when not such a PNG, kInvalidArgument
// for another size.
Status check_instance_mask_header(const std::string& path, int width, int height);

}  // namespace sitepose::io
