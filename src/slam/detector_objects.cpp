#include "sitepose/slam/detector_objects.hpp"

#include <memory>

namespace sitepose::slam {

Expected<dynamic::FrameObjects> detect_objects(detect::Detector& detector, const StereoFrame& frame) {
  SITEPOSE_TRY(std::vector<detect::Detection> detections, detector.detect(frame));
  dynamic::FrameObjects out;
  for (const detect::Detection& d : detections) {
    out.boxes.push_back({d.instance, d.class_name, d.score, d.box});
  }
  if (detector.capabilities().has_segmentation) {
    auto shared = std::make_shared<std::vector<detect::Detection>>(std::move(detections));
    out.segment = [&detector, &frame, shared](const std::vector<dynamic::ObjectBox>& boxes) {
      // Segment only the boxes the masker kept (dynamic classes).
      std::vector<detect::Detection> wanted;
      for (const detect::Detection& d : *shared) {
        for (const dynamic::ObjectBox& b : boxes) {
          if (b.instance == d.instance) wanted.push_back(d);
        }
      }
      return detector.segment(frame, wanted);
    };
  }
  return out;
}

}  // namespace sitepose::slam
