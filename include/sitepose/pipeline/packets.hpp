#pragma once
// What crosses the pipeline's rings (ARCHITECTURE.md "One frame's way
// through the daemon"): FramePacket from capture to detect to track,
// PosePacket from track to publish.
// Ownership: packets are moved from stage to stage, never shared; the
// StereoFrame's pixels are treated as const once captured (cv::Mat headers
// share pixel buffers).

#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>

#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/dynamic/object_types.hpp"

namespace sitepose::pipeline {

using SteadyClock = std::chrono::steady_clock;
using SteadyTime = SteadyClock::time_point;

enum class PacketKind {
  kFrame,  // a stereo frame from the source
  kStall,  // the source delivered no frame within pipeline.stall_timeout_s
};

struct FramePacket {
  PacketKind kind = PacketKind::kFrame;
  StereoFrame frame;          // kFrame only
  std::int64_t stall_ns = 0;  // kStall: how long the capture stage waited in vain
  // When the capture stage got the frame (kStall: when it gave up waiting);
  // frame-to-publish latency is measured from here.
  SteadyTime captured{};
  // Filled by the detect hook (hooks.hpp). `detected`: the detector ran on
  // this frame and `objects` are its boxes (possibly none); false after a
  // detector error and with the pass-through hook.
  bool detected = false;
  std::vector<dynamic::ObjectBox> objects;
  // Pixel instance masks of the dynamic objects (CV_16UC1, 0 = background,
  // FORMATS.md labels/masks) when Algorithm 1 asked for them this frame
  // (dynamic::wants_pixel_mask); empty otherwise.
  cv::Mat instance_mask;
};

struct PosePacket {
  PoseEstimate pose;
  // True for the LOST report the track stage emits for a kStall packet; its
  // pose repeats the seq and T_world_cam of the last frame, t_ns is the last
  // frame's time plus the stall time.
  bool from_stall = false;
  SteadyTime captured{};  // copied from the FramePacket
};

}  // namespace sitepose::pipeline
