#pragma once
// PoseTracker over the positioning core (slam::SlamSystem) for the track
// stage. The local mapper runs on its own thread (SlamOptions::mapper_thread),
// as ARCHITECTURE.md asks of the daemon.
//
// dynamic.mode none: every frame is plain stereo SLAM (process(frame)).
// Other modes: the detect stage's boxes and pixel masks (DetectorStage)
// go to process(frame, objects):
//   * a pixel mask Algorithm 1 wants but the detect stage did not make
//     (detector without segmentation, segment() failed) is replaced by the
//     box mask, which covers more, never less;
//   * a frame the detector failed on (packet.detected false) is tracked
//     with the last detected frame's boxes when that frame is at most
//     kMaxDetectionReuseS older; otherwise without masks, and its pose is
//     at most RECOVERING ("no detections") so nobody steers on a pose the
//     machines around may have pulled along.
// Counters of both fallbacks: fallback_counters().
// Threads: track() and finish() on the track thread only; the counters
// from any thread.

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/dynamic/object_types.hpp"
#include "sitepose/pipeline/hooks.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::pipeline {

inline constexpr double kMaxDetectionReuseS = 0.5;

struct TrackerFallbackCounters {
  std::uint64_t box_mask_for_pixel_mask = 0;  // pixel mask wanted, none made
  std::uint64_t reused_detections = 0;        // frames tracked with the last frame's boxes
  std::uint64_t tracked_unmasked = 0;         // frames tracked without any detection
};

class SlamPoseTracker final : public PoseTracker {
 public:
  // fps: the source's frame rate (FrameSource::frame_rate_hz(); 0 = unknown,
  // kAssumedFrameRateHz then). Errors from SlamSystem::create (camera or config invalid).
  static Expected<std::unique_ptr<SlamPoseTracker>> create(const StereoCamera& camera,
                                                           const config::SiteposeConfig& config,
                                                           double fps = 0.0);
  Expected<PoseEstimate> track(const FramePacket& packet) override;
  void finish() override;
  TrackerFallbackCounters fallback_counters() const;
  // Map size, from any thread (the map's own lock).
  std::size_t keyframe_count() const;
  std::size_t point_count() const;
  // A saved map to start in: before the first frame (slam::SlamSystem::load_map).
  Status load_map(map::MapData map) { return system_->load_map(std::move(map)); }
  // A copy of the map under its read lock, from any thread (checkpoints).
  map::MapData copy_map() const { return system_->copy_map(); }

 private:
  explicit SlamPoseTracker(std::unique_ptr<slam::SlamSystem> system) : system_(std::move(system)) {}
  Expected<PoseEstimate> track_with_objects(const FramePacket& packet);

  std::unique_ptr<slam::SlamSystem> system_;
  bool finished_ = false;
  // The last detected frame (track thread only).
  std::vector<dynamic::ObjectBox> last_objects_;
  std::int64_t last_detected_t_ns_ = 0;
  bool have_last_objects_ = false;
  std::atomic<std::uint64_t> box_mask_for_pixel_mask_{0};
  std::atomic<std::uint64_t> reused_detections_{0};
  std::atomic<std::uint64_t> tracked_unmasked_{0};
};

}  // namespace sitepose::pipeline
