#pragma once
// The three points where the daemon plugs algorithms and I/O into the
// pipeline (pipeline.hpp), each called on one stage thread only:
//   DetectHook  - detect stage: annotates a frame (detector boxes, instance
//                 masks). PassThroughDetect does nothing (dynamic.mode none);
//                 DetectorStage (detect_stage.hpp) runs a detector plugin.
//   PoseTracker - track stage: the positioning core (SlamPoseTracker in
//                 slam_tracker.hpp).
//   PoseOutput  - publish stage: LCM, CAN, trajectory file... (the daemon's
//                 outputs in src/daemon/). The stage retries a failed
//                 pose through retry() and counts errors (pipeline.hpp).
// Ownership: the pipeline owns the hooks (unique_ptr) and destroys them
// after their thread has ended.

#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/pipeline/health.hpp"
#include "sitepose/pipeline/packets.hpp"

namespace sitepose::pipeline {

class DetectHook {
 public:
  virtual ~DetectHook() = default;
  virtual std::string name() const = 0;
  // Every kFrame packet, in order. May fill packet.detected, objects and
  // instance_mask; must not write into the frame's pixels. An error is
  // counted and logged, and the frame goes on unannotated.
  virtual Status annotate(FramePacket& packet) = 0;
};

// Frames pass through unannotated (dynamic.mode none).
class PassThroughDetect final : public DetectHook {
 public:
  std::string name() const override { return "pass-through"; }
  Status annotate(FramePacket&) override { return ok_status(); }
};

class PoseTracker {
 public:
  virtual ~PoseTracker() = default;
  // Every kFrame packet, in time order. Tracking failure is a state in the
  // returned pose; an error means the frame was rejected as bad input (the
  // stage then publishes a LOST pose naming the reason and goes on).
  virtual Expected<PoseEstimate> track(const FramePacket& packet) = 0;
  // Once, after the last frame (lets a mapper thread finish).
  virtual void finish() {}
};

class PoseOutput {
 public:
  virtual ~PoseOutput() = default;
  virtual std::string name() const = 0;
  // Sends one pose. When it returned ok, the pose is with the OS (written
  // and flushed, or sent): a stop loses nothing that publish() confirmed.
  // An unfinished previous pose is abandoned.
  virtual Status publish(const PosePacket& packet) = 0;
  // Resumes the pose whose publish() or retry() failed, sending only what
  // was not sent yet (no duplicates). Only called after such a failure.
  virtual Status retry() = 0;
  // About once per health interval; the default publishes nothing.
  virtual Status publish_health(const PipelineHealth&) { return ok_status(); }
};

}  // namespace sitepose::pipeline
