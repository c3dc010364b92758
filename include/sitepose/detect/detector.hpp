#pragma once
// The object detector seen by the dynamic layer (METHOD.md, Algorithm 1):
// boxes of objects in the left image, optionally pixel instance masks.
//
// Every Detector sitepose creates is a plugin behind the C ABI of
// plugin_abi.h (the built-ins included); see plugin_loader.hpp and
// create_detector.hpp.
//
// Threads: one Detector is used by one thread at a time (the detect stage);
// nothing is shared between Detector objects. health() may be read by the
// same thread between calls.
// Failure: a plugin call that fails returns an Error (kRuntime) naming the
// plugin, the frame and the plugin's message, and counts in health(); the
// caller decides whether the frame goes on without detections. Invalid
// individual detections never fail a call: they are dropped and counted.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_frame.hpp"

namespace sitepose::detect {

struct Detection {
  std::string class_name;      // e.g. truck, roller, object (stereo-geometric)
  double score = 0.0;          // [0, 1]
  cv::Rect box;                // left-image pixels, inside the image, non-empty
  std::uint16_t instance = 0;  // > 0; stable across frames when capabilities().tracks_ids
};

struct DetectorCapabilities {
  bool has_segmentation = false;  // segment() gives pixel masks
  bool tracks_ids = false;        // instance ids are stable across frames (else unique per frame)
};

// Counters since the detector was created.
struct DetectorHealth {
  std::int64_t frames = 0;               // detect() calls
  std::int64_t detections = 0;           // detections returned to the caller
  std::int64_t dropped_detections = 0;   // invalid ones dropped (see plugin_abi.h)
  std::int64_t failed_calls = 0;         // detect()/segment() calls the plugin failed
  std::int64_t segment_calls = 0;        // segment() calls
  std::int64_t cleared_mask_pixels = 0;  // mask pixels outside their box / of no detection
};

class Detector {
 public:
  virtual ~Detector() = default;

  // The name it was created with (built-in name or plugin path).
  virtual const std::string& name() const = 0;
  virtual DetectorCapabilities capabilities() const = 0;

  // Objects in frame.left (frame.right available to stereo detectors).
  virtual Expected<std::vector<Detection>> detect(const StereoFrame& frame) = 0;

  // CV_16UC1 left-image-sized instance mask: pixel = instance id of one of
  // `detections` (0 = background); non-zero only inside that detection's
  // box. kUnsupported when !capabilities().has_segmentation.
  virtual Expected<cv::Mat> segment(const StereoFrame& frame,
                                    const std::vector<Detection>& detections) = 0;

  virtual DetectorHealth health() const = 0;
};

}  // namespace sitepose::detect
