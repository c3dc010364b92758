#include "sitepose/pipeline/detect_stage.hpp"

#include "sitepose/dynamic/masking.hpp"

namespace sitepose::pipeline {

DetectorStage::DetectorStage(std::unique_ptr<detect::Detector> detector, const config::DynamicConfig& dynamic)
    : detector_(std::move(detector)), dynamic_(dynamic) {}

std::string DetectorStage::name() const { return "detector " + detector_->name(); }

Status DetectorStage::annotate(FramePacket& packet) {
  const StereoFrame& frame = packet.frame;
  SITEPOSE_TRY(std::vector<detect::Detection> detections, detector_->detect(frame));
  packet.objects.clear();
  for (const detect::Detection& d : detections) {
    packet.objects.push_back({d.instance, d.class_name, d.score, d.box});
  }
  packet.detected = true;

  const std::vector<dynamic::ObjectBox> dynamic_boxes =
      dynamic::dynamic_boxes(packet.objects, frame.left.size(), dynamic_);
  if (dynamic_boxes.empty() || !detector_->capabilities().has_segmentation) return ok_status();
  const double mar = dynamic::box_union_ratio(dynamic_boxes, frame.left.size());
  if (!dynamic::wants_pixel_mask(dynamic_.mode, mar, dynamic_)) return ok_status();
  std::vector<detect::Detection> wanted;
  for (const detect::Detection& d : detections) {
    for (const dynamic::ObjectBox& b : dynamic_boxes) {
      if (b.instance == d.instance) wanted.push_back(d);
    }
  }
  SITEPOSE_TRY(packet.instance_mask, detector_->segment(frame, wanted));
  return ok_status();
}

Expected<std::unique_ptr<DetectHook>> make_detect_hook(const config::SiteposeConfig& config,
                                                       const detect::DetectorContext& context,
                                                       const detect::IsolationOptions& isolation) {
  if (config.dynamic.mode == config::MaskingMode::kNone) {
    return std::unique_ptr<DetectHook>(std::make_unique<PassThroughDetect>());
  }
  SITEPOSE_TRY(auto detector, detect::create_detector(config.detector, context, isolation));
  if (config.dynamic.mode == config::MaskingMode::kPixel && !detector->capabilities().has_segmentation) {
    return make_error(ErrorCode::kInvalidArgument,
                      "dynamic.mode pixel: detector \"" + config.detector.name +
                          "\" gives no pixel masks (choose bbox, hierarchical or full)");
  }
  return std::unique_ptr<DetectHook>(std::make_unique<DetectorStage>(std::move(detector), config.dynamic));
}

}  // namespace sitepose::pipeline
