#include "sitepose/pipeline/slam_tracker.hpp"

namespace sitepose::pipeline {

Expected<std::unique_ptr<SlamPoseTracker>> SlamPoseTracker::create(
    const StereoCamera& camera, const config::SiteposeConfig& config) {
  slam::SlamOptions options;
  options.mapper_thread = true;
  SITEPOSE_TRY(auto system, slam::SlamSystem::create(camera, config, options));
  return std::unique_ptr<SlamPoseTracker>(new SlamPoseTracker(std::move(system)));
}

Expected<PoseEstimate> SlamPoseTracker::track(const FramePacket& packet) {
  SITEPOSE_TRY(slam::FrameReport report, system_->process(packet.frame));
  return std::move(report.pose);
}

void SlamPoseTracker::finish() {
  if (finished_) return;
  finished_ = true;
  system_->finish();
}

}  // namespace sitepose::pipeline
