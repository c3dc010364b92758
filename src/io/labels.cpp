#include "sitepose/io/labels.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <utility>

#include "detail/text.hpp"
#include "sitepose/core/echo.hpp"

namespace sitepose::io {
namespace {

constexpr const char* kBoxesHeader = "frame,instance,class,x,y,w,h,moving";
constexpr std::size_t kBoxesFields = 8;
// Instance ids are mask pixel values, so they must fit 16 bits.
constexpr int kMaxInstanceId = 65535;

bool is_word(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-';
  });
}

Expected<int> parse_int_field(const std::string& path, std::size_t line_no, std::string_view name,
                              std::string_view token) {
  const std::optional<std::int64_t> v = detail::parse_int64(token);
  if (!v || *v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max()) {
    return make_error(ErrorCode::kParseError, detail::where(path, line_no) + "field '" + std::string(name) +
                                                  "': expected an integer, got '" + echo_value(token) + "'");
  }
  return static_cast<int>(*v);
}

Expected<double> parse_number_field(const std::string& path, std::size_t line_no, std::string_view name,
                                    std::string_view token) {
  const std::optional<double> v = detail::parse_double(token);
  // Pixel coordinates beyond +-1e6 would overflow cv::Rect's int arithmetic.
  if (!v || std::abs(*v) > 1e6) {
    return make_error(ErrorCode::kParseError, detail::where(path, line_no) + "field '" + std::string(name) +
                                                  "': expected a pixel coordinate, got '" +
                                                  echo_value(token) + "'");
  }
  return *v;
}

}  // namespace

namespace {

// One row "frame,instance,class,x,y,w,h,moving" (already split in 8 fields).
Expected<LabelBox> parse_box_row(const std::string& path, std::size_t line_no,
                                 const std::vector<std::string_view>& f,
                                 std::optional<std::size_t> n_frames) {
  LabelBox box;
  SITEPOSE_TRY(box.frame, parse_int_field(path, line_no, "frame", f[0]));
  SITEPOSE_TRY(box.instance, parse_int_field(path, line_no, "instance", f[1]));
  if (box.frame < 0) {
    return make_error(
        ErrorCode::kParseError,
        detail::where(path, line_no) + "field 'frame': expected >= 0, got " + std::to_string(box.frame));
  }
  if (n_frames && static_cast<std::size_t>(box.frame) >= *n_frames) {
    return make_error(ErrorCode::kParseError, detail::where(path, line_no) + "field 'frame': expected < " +
                                                  std::to_string(*n_frames) +
                                                  " (frames in the sequence), got " +
                                                  std::to_string(box.frame));
  }
  if (box.instance <= 0 || box.instance > kMaxInstanceId) {
    return make_error(
        ErrorCode::kParseError,
        detail::where(path, line_no) + "field 'instance': expected 1.." + std::to_string(kMaxInstanceId) +
            " (0 is the mask background; masks are 16-bit PNGs), got " + std::to_string(box.instance));
  }
  if (!is_word(f[2])) {
    return make_error(
        ErrorCode::kParseError,
        detail::where(path, line_no) + "field 'class': expected one word, got '" + echo_value(f[2]) + "'");
  }
  box.class_name = std::string(f[2]);
  SITEPOSE_TRY(const double x, parse_number_field(path, line_no, "x", f[3]));
  SITEPOSE_TRY(const double y, parse_number_field(path, line_no, "y", f[4]));
  SITEPOSE_TRY(const double w, parse_number_field(path, line_no, "w", f[5]));
  SITEPOSE_TRY(const double h, parse_number_field(path, line_no, "h", f[6]));
  if (!(w > 0.0) || !(h > 0.0)) {
    return make_error(ErrorCode::kParseError, detail::where(path, line_no) +
                                                  "fields 'w', 'h': expected > 0, got '" + echo_value(f[5]) +
                                                  "', '" + echo_value(f[6]) + "'");
  }
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  box.box =
      cv::Rect(x0, y0, static_cast<int>(std::ceil(x + w)) - x0, static_cast<int>(std::ceil(y + h)) - y0);
  if (f[7] == "1") {
    box.moving = true;
  } else if (f[7] == "0") {
    box.moving = false;
  } else if (!f[7].empty()) {
    return make_error(ErrorCode::kParseError, detail::where(path, line_no) +
                                                  "field 'moving': expected 1, 0 or empty (unknown), got '" +
                                                  echo_value(f[7]) + "'");
  }
  return box;
}

}  // namespace

Expected<std::vector<LabelBox>> read_boxes_csv(const std::string& path, std::optional<std::size_t> n_frames) {
  SITEPOSE_TRY(const std::vector<std::string> lines, detail::read_lines(path));
  if (lines.empty() || detail::trim(lines[0]) != kBoxesHeader) {
    return make_error(ErrorCode::kParseError,
                      detail::where(path, 1) + "expected the header '" + kBoxesHeader + "', got '" +
                          (lines.empty() ? std::string() : echo_value(lines[0])) + "'");
  }
  std::vector<LabelBox> boxes;
  std::set<std::pair<int, int>> seen;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::size_t line_no = i + 1;
    if (detail::is_blank(lines[i])) continue;
    const std::vector<std::string_view> f = detail::split_fields(lines[i], ',');
    if (f.size() != kBoxesFields) {
      return make_error(ErrorCode::kParseError, detail::where(path, line_no) + "expected 8 fields (" +
                                                    kBoxesHeader + "), got " + std::to_string(f.size()));
    }
    SITEPOSE_TRY(LabelBox box, parse_box_row(path, line_no, f, n_frames));
    if (!seen.emplace(box.frame, box.instance).second) {
      return make_error(ErrorCode::kParseError, detail::where(path, line_no) + "instance " +
                                                    std::to_string(box.instance) +
                                                    " appears twice in frame " + std::to_string(box.frame) +
                                                    "; expected one row per (frame, instance)");
    }
    boxes.push_back(std::move(box));
  }
  std::stable_sort(boxes.begin(), boxes.end(), [](const LabelBox& a, const LabelBox& b) {
    return std::pair(a.frame, a.instance) < std::pair(b.frame, b.instance);
  });
  return boxes;
}

Expected<cv::Mat> read_instance_mask(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, path + ": mask file does not exist");
  }
  cv::Mat mask = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (mask.empty()) {
    return make_error(ErrorCode::kParseError, path + ": cannot decode as an image");
  }
  if (mask.type() != CV_16UC1) {
    const int bits = mask.depth() == CV_8U ? 8 : mask.depth() == CV_16U ? 16 : 0;
    return make_error(ErrorCode::kParseError,
                      path + ": expected a 16-bit single-channel PNG (instance ids), got " +
                          (bits > 0 ? std::to_string(bits) + "-bit" : std::string("non-integer")) + " with " +
                          std::to_string(mask.channels()) + " channel(s)");
  }
  return mask;
}

Status check_instance_mask_header(const std::string& path, int width, int height) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, path + ": mask file does not exist");
  }
  // Signature (8 bytes), then the IHDR chunk: length, "IHDR", width and
  // height (big endian), bit depth, colour type (0 = gray).
  unsigned char head[26] = {};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (in.gcount() != static_cast<std::streamsize>(sizeof(head)) ||
      !std::equal(std::begin(kSignature), std::end(kSignature), head) ||
      std::string_view(reinterpret_cast<const char*>(head + 12), 4) != "IHDR") {
    return make_error(ErrorCode::kParseError, path + ": not a PNG file (expected a 16-bit instance mask)");
  }
  const auto be32 = [&](int at) {
    return (std::uint32_t{head[at]} << 24) | (std::uint32_t{head[at + 1]} << 16) |
           (std::uint32_t{head[at + 2]} << 8) | std::uint32_t{head[at + 3]};
  };
  const int bit_depth = head[24], colour_type = head[25];
  if (bit_depth != 16 || colour_type != 0) {
    return make_error(ErrorCode::kParseError,
                      path + ": expected a 16-bit single-channel PNG (instance ids), got " +
                          std::to_string(bit_depth) + "-bit " +
                          (colour_type == 0 ? "gray" : "colour or palette"));
  }
  if (be32(16) != static_cast<std::uint32_t>(width) || be32(20) != static_cast<std::uint32_t>(height)) {
    return make_error(ErrorCode::kInvalidArgument, path + ": mask is " + std::to_string(be32(16)) + "x" +
                                                       std::to_string(be32(20)) + ", expected " +
                                                       std::to_string(width) + "x" + std::to_string(height) +
                                                       " (the image size)");
  }
  return ok_status();
}

}  // namespace sitepose::io
