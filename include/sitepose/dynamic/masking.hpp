#pragma once
// Hierarchical masking, Algorithm 1 of the paper (METHOD.md "Hierarchical
// masking"): a box mask from the boxes of a-priori dynamic classes; when
// their union covers at least tau_mar of the image, pixel-wise segmentation
// replaces the box mask.
//
// The mask is an instance-label image (CV_16UC1, left image): 0 = not
// masked, otherwise the instance id of the object covering the pixel. The
// tracker tags keypoints with it, so the motion-state classifier and pass 2
// can unmask one object at a time.
// Pure functions; thread-safe as long as the segmenter is.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/dynamic/object_types.hpp"

namespace sitepose::dynamic {

struct MaskResult {
  cv::Mat instance_labels;               // CV_16UC1, 0 = unmasked; empty for mode none
  std::vector<ObjectBox> dynamic_boxes;  // boxes of a-priori dynamic classes, clipped
  double mar = 0.0;                      // union of dynamic boxes / image area (Algorithm 1)
  double masked_ratio = 0.0;             // pixels actually masked / image area
  bool pixel_mask_used = false;          // the segmenter was called this frame
  double segment_ms = 0.0;               // wall time of that call (the detector's work)
};

// True when `class_name` is in the a-priori dynamic classes (exact, case-
// sensitive match; classes are lower-case words by convention).
bool is_dynamic_class(const std::string& class_name, const std::vector<std::string>& dynamic_classes);

// Union area of the boxes (clipped to the image) / image area, in [0, 1].
double box_union_ratio(const std::vector<ObjectBox>& boxes, cv::Size image_size);

// Box-filled instance labels; where boxes overlap, the smaller box wins (it
// is usually the nearer object drawn in front).
cv::Mat box_instance_labels(const std::vector<ObjectBox>& boxes, cv::Size image_size);

// The boxes of a-priori dynamic classes with an instance id, clipped to the
// image; empty ones dropped.
std::vector<ObjectBox> dynamic_boxes(const std::vector<ObjectBox>& boxes, cv::Size image_size,
                                     const config::DynamicConfig& config);

// Algorithm 1's switch: does `mode` segment pixels when the dynamic boxes
// cover `mar` of the image? (pixel: always; hierarchical, full: mar >=
// tau_mar; none, bbox: never.) The daemon's detect stage asks this to
// segment before the track stage needs it.
bool wants_pixel_mask(config::MaskingMode mode, double mar, const config::DynamicConfig& config);

// Algorithm 1 for one frame. Modes: none -> empty labels (mar still
// reported); bbox -> box mask; pixel -> segmentation always; hierarchical
// and full -> segmentation only when mar >= tau_mar. Pixels of the
// segmentation whose id is not one of the dynamic boxes are ignored; the
// pixel mask is dilated by 4 px (silhouette corners move with the object).
// Errors: kUnsupported when a pixel mask is needed and `objects.segment` is
// empty; the segmenter's own error; kInvalidArgument when it returns an
// image of the wrong type or size.
Expected<MaskResult> build_mask(config::MaskingMode mode, const FrameObjects& objects, cv::Size image_size,
                                const config::DynamicConfig& config);

// The tracker's extraction mask for `mask` (Tracker::prepare): nonzero where
// an object is masked; empty when the mode masks nothing.
cv::Mat extraction_mask(const MaskResult& mask);

}  // namespace sitepose::dynamic
