#pragma once
// PoseTracker over the positioning core (slam::SlamSystem) for the track
// stage. The local mapper runs on its own thread (SlamOptions::mapper_thread),
// as ARCHITECTURE.md asks of the daemon.
// The detect stage's instance mask is not passed on: SlamSystem takes none
// in this build (the dynamic layer will consume it through this adapter).
// Threads: track() and finish() on the track thread only.

#include <memory>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/pipeline/hooks.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::pipeline {

class SlamPoseTracker final : public PoseTracker {
 public:
  // Errors from SlamSystem::create (camera or config invalid).
  static Expected<std::unique_ptr<SlamPoseTracker>> create(const StereoCamera& camera,
                                                           const config::SiteposeConfig& config);
  Expected<PoseEstimate> track(const FramePacket& packet) override;
  void finish() override;

 private:
  explicit SlamPoseTracker(std::unique_ptr<slam::SlamSystem> system) : system_(std::move(system)) {}
  std::unique_ptr<slam::SlamSystem> system_;
  bool finished_ = false;
};

}  // namespace sitepose::pipeline
