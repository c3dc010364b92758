#pragma once
// Glue between a detect::Detector and the dynamic layer: one detect() call
// per frame, segmentation on demand (Algorithm 1 asks only when mar >= tau).

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/detect/detector.hpp"
#include "sitepose/dynamic/object_types.hpp"

namespace sitepose::slam {

// The detector's boxes for `frame` as dynamic::ObjectBox; the segmenter (set
// when the detector can segment) calls detector.segment(frame, detections).
// Lifetime: the result refers to `detector` and `frame`; use it (process())
// before either goes away. Errors: the detector's.
Expected<dynamic::FrameObjects> detect_objects(detect::Detector& detector, const StereoFrame& frame);

}  // namespace sitepose::slam
