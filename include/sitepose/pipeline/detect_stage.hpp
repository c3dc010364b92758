#pragma once
// The daemon's detect stage with a detector (dynamic.mode other than none):
// the detector half of Algorithm 1 on the detect thread, so detection of
// frame n+1 overlaps tracking of frame n.
//   * detect() on every frame -> packet.objects, packet.detected = true;
//   * when dynamic::wants_pixel_mask() says this frame's mode and mar need
//     pixel masks and the detector can segment, segment() the dynamic-class
//     boxes -> packet.instance_mask. (A detector without segmentation leaves
//     it empty; the track stage then masks those frames by box, which covers
//     more, never less.)
// A failed detect() or segment() is an error for the stage to count; the
// frame goes on with detected = false (detect) or without the pixel mask
// (segment). The track stage decides what an undetected frame means
// (SlamPoseTracker).
// Threads: annotate() on the detect thread only; the detector is owned.

#include <memory>
#include <string>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/detect/create_detector.hpp"
#include "sitepose/detect/detector.hpp"
#include "sitepose/pipeline/hooks.hpp"

namespace sitepose::pipeline {

class DetectorStage final : public DetectHook {
 public:
  DetectorStage(std::unique_ptr<detect::Detector> detector, const config::DynamicConfig& dynamic);
  std::string name() const override;
  Status annotate(FramePacket& packet) override;

 private:
  std::unique_ptr<detect::Detector> detector_;
  config::DynamicConfig dynamic_;
};

// The detect hook for `config` (siteposed and `sitepose bench pipeline`):
// PassThroughDetect in dynamic.mode none, else a DetectorStage over
// detect::create_detector(config.detector, context). Errors: the
// detector's; kInvalidArgument for mode pixel with a detector that cannot
// segment (the other modes fall back to box masks).
// `isolation` as create_detector() takes it.
Expected<std::unique_ptr<DetectHook>> make_detect_hook(const config::SiteposeConfig& config,
                                                       const detect::DetectorContext& context,
                                                       const detect::IsolationOptions& isolation = {});

}  // namespace sitepose::pipeline
