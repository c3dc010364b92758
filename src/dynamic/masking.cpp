#include "sitepose/dynamic/masking.hpp"

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "sitepose/core/enum_names.hpp"
#include "sitepose/core/stopwatch.hpp"

namespace sitepose::dynamic {
namespace {
// Pixel masks grow by this much: a FAST corner on an object's silhouette
// moves with the object even when its centre pixel is background (the
// authors used no dilation; box masks have the margin built in). More
// dilation throws away the background next to the machines that the pixel
// mask is there to keep.
constexpr int kPixelMaskDilationPx = 4;
}  // namespace

constexpr auto kMotionStateNames = enum_names<MotionState>(
    {{MotionState::kUnknown, "unknown"}, {MotionState::kStatic, "static"}, {MotionState::kMoving, "moving"}},
    "unknown");

const char* to_string(MotionState state) { return kMotionStateNames.name(state); }

const char* to_string(UnknownReason reason) {
  switch (reason) {
    case UnknownReason::kNoReference: return "no_reference";
    case UnknownReason::kTooFewPoints: return "too_few_points";
    case UnknownReason::kAmbiguous: return "ambiguous";
    case UnknownReason::kSettling: return "settling";
    case UnknownReason::kNone: break;
  }
  return "";
}

bool is_dynamic_class(const std::string& class_name, const std::vector<std::string>& dynamic_classes) {
  return std::find(dynamic_classes.begin(), dynamic_classes.end(), class_name) != dynamic_classes.end();
}

double box_union_ratio(const std::vector<ObjectBox>& boxes, cv::Size image_size) {
  if (image_size.area() <= 0) return 0.0;
  cv::Mat covered = cv::Mat::zeros(image_size, CV_8UC1);
  const cv::Rect image(cv::Point(0, 0), image_size);
  for (const ObjectBox& b : boxes) {
    const cv::Rect r = b.box & image;
    if (r.area() > 0) covered(r).setTo(1);
  }
  return static_cast<double>(cv::countNonZero(covered)) / image_size.area();
}

cv::Mat box_instance_labels(const std::vector<ObjectBox>& boxes, cv::Size image_size) {
  cv::Mat labels = cv::Mat::zeros(image_size, CV_16UC1);
  const cv::Rect image(cv::Point(0, 0), image_size);
  std::vector<const ObjectBox*> by_area;
  by_area.reserve(boxes.size());
  for (const ObjectBox& b : boxes) by_area.push_back(&b);
  // Largest first, so smaller (usually nearer, in front) boxes overwrite.
  std::stable_sort(by_area.begin(), by_area.end(),
                   [](const ObjectBox* a, const ObjectBox* b) { return a->box.area() > b->box.area(); });
  for (const ObjectBox* b : by_area) {
    const cv::Rect r = b->box & image;
    if (r.area() > 0) labels(r).setTo(b->instance);
  }
  return labels;
}

std::vector<ObjectBox> dynamic_boxes(const std::vector<ObjectBox>& boxes, cv::Size image_size,
                                     const config::DynamicConfig& config) {
  std::vector<ObjectBox> out;
  const cv::Rect image(cv::Point(0, 0), image_size);
  for (const ObjectBox& b : boxes) {
    if (!is_dynamic_class(b.class_name, config.dynamic_classes)) continue;
    ObjectBox clipped = b;
    clipped.box = b.box & image;
    if (clipped.box.area() > 0 && b.instance > 0) out.push_back(std::move(clipped));
  }
  return out;
}

bool wants_pixel_mask(config::MaskingMode mode, double mar, const config::DynamicConfig& config) {
  return mode == config::MaskingMode::kPixel ||
         ((mode == config::MaskingMode::kHierarchical || mode == config::MaskingMode::kFull) &&
          mar >= config.tau_mar);
}

Expected<MaskResult> build_mask(config::MaskingMode mode, const FrameObjects& objects, cv::Size image_size,
                                const config::DynamicConfig& config) {
  MaskResult out;
  out.dynamic_boxes = dynamic_boxes(objects.boxes, image_size, config);
  out.mar = box_union_ratio(out.dynamic_boxes, image_size);
  if (mode == config::MaskingMode::kNone) return out;

  const bool want_pixels = wants_pixel_mask(mode, out.mar, config);
  if (!want_pixels || out.dynamic_boxes.empty()) {
    out.instance_labels = box_instance_labels(out.dynamic_boxes, image_size);
  } else {
    if (!objects.segment) {
      return make_error(ErrorCode::kUnsupported, std::string("mode ") + config::to_string(mode) +
                                                     " needs pixel masks (mar " + std::to_string(out.mar) +
                                                     "), but the detector has no segmentation");
    }
    const auto segment_start = SteadyClock::now();
    SITEPOSE_TRY(cv::Mat segmented, objects.segment(out.dynamic_boxes));
    out.segment_ms = ms_since(segment_start);
    if (segmented.type() != CV_16UC1 || segmented.size() != image_size) {
      return make_error(ErrorCode::kInvalidArgument,
                        "pixel segmentation returned a " + std::to_string(segmented.cols) + "x" +
                            std::to_string(segmented.rows) + " image of type " +
                            std::to_string(segmented.type()) + "; expected CV_16UC1 of the image size");
    }
    // Keep only the pixels of dynamic-class instances.
    std::vector<std::uint8_t> wanted(65536, 0);
    for (const ObjectBox& b : out.dynamic_boxes) wanted[b.instance] = 1;
    out.instance_labels = cv::Mat::zeros(image_size, CV_16UC1);
    for (int y = 0; y < image_size.height; ++y) {
      const std::uint16_t* src = segmented.ptr<std::uint16_t>(y);
      std::uint16_t* dst = out.instance_labels.ptr<std::uint16_t>(y);
      for (int x = 0; x < image_size.width; ++x) {
        if (wanted[src[x]] != 0) dst[x] = src[x];
      }
    }
    const cv::Mat kernel = cv::getStructuringElement(
        cv::MORPH_ELLIPSE, cv::Size(2 * kPixelMaskDilationPx + 1, 2 * kPixelMaskDilationPx + 1));
    cv::dilate(out.instance_labels, out.instance_labels, kernel);
    out.pixel_mask_used = true;
  }
  out.masked_ratio =
      static_cast<double>(cv::countNonZero(out.instance_labels)) / std::max(1, image_size.area());
  return out;
}

cv::Mat extraction_mask(const MaskResult& mask) {
  if (mask.instance_labels.empty()) return {};
  return mask.instance_labels != 0;
}

}  // namespace sitepose::dynamic
