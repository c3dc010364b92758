#include "sitepose/pipeline/slam_tracker.hpp"

#include <algorithm>

#include "sitepose/dynamic/masking.hpp"
#include "sitepose/pipeline/frame_source.hpp"

namespace sitepose::pipeline {

Expected<std::unique_ptr<SlamPoseTracker>> SlamPoseTracker::create(const StereoCamera& camera,
                                                                   const config::SiteposeConfig& config,
                                                                   double fps) {
  slam::SlamOptions options;
  options.mapper_thread = true;
  options.fps = known_or_assumed_frame_rate_hz(fps);
  SITEPOSE_TRY(auto system, slam::SlamSystem::create(camera, config, options));
  return std::unique_ptr<SlamPoseTracker>(new SlamPoseTracker(std::move(system)));
}

Expected<PoseEstimate> SlamPoseTracker::track(const FramePacket& packet) {
  if (system_->mode() == config::MaskingMode::kNone) {
    SITEPOSE_TRY(slam::FrameReport report, system_->process(packet.frame));
    return std::move(report.pose);
  }
  return track_with_objects(packet);
}

Expected<PoseEstimate> SlamPoseTracker::track_with_objects(const FramePacket& packet) {
  const StereoFrame& frame = packet.frame;
  const std::vector<dynamic::ObjectBox>* boxes = &packet.objects;
  if (packet.detected) {
    last_objects_ = packet.objects;
    last_detected_t_ns_ = frame.t_ns();
    have_last_objects_ = true;
  } else if (have_last_objects_ &&
             static_cast<double>(frame.t_ns() - last_detected_t_ns_) * 1e-9 <= kMaxDetectionReuseS) {
    boxes = &last_objects_;
    reused_detections_.fetch_add(1, std::memory_order_relaxed);
  } else {
    tracked_unmasked_.fetch_add(1, std::memory_order_relaxed);
    SITEPOSE_TRY(slam::FrameReport report, system_->process(frame));
    if (report.pose.state == TrackingState::kOk) {
      report.pose.state = TrackingState::kRecovering;
      report.pose.state_reason = "no detections: tracked without masking";
    }
    return std::move(report.pose);
  }

  dynamic::FrameObjects objects;
  objects.boxes = *boxes;
  const cv::Mat& pixel_mask = packet.detected ? packet.instance_mask : cv::Mat();
  const cv::Size size = frame.left.size();
  objects.segment = [this, &pixel_mask,
                     size](const std::vector<dynamic::ObjectBox>& wanted) -> Expected<cv::Mat> {
    if (!pixel_mask.empty()) return pixel_mask;
    box_mask_for_pixel_mask_.fetch_add(1, std::memory_order_relaxed);
    return dynamic::box_instance_labels(wanted, size);
  };
  SITEPOSE_TRY(slam::FrameReport report, system_->process(frame, objects));
  return std::move(report.pose);
}

std::size_t SlamPoseTracker::keyframe_count() const { return system_->keyframe_count(); }
std::size_t SlamPoseTracker::point_count() const { return system_->point_count(); }

TrackerFallbackCounters SlamPoseTracker::fallback_counters() const {
  return {box_mask_for_pixel_mask_.load(std::memory_order_relaxed),
          reused_detections_.load(std::memory_order_relaxed),
          tracked_unmasked_.load(std::memory_order_relaxed)};
}

void SlamPoseTracker::finish() {
  if (finished_) return;
  finished_ = true;
  system_->finish();
}

}  // namespace sitepose::pipeline
