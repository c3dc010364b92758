#pragma once
// Where the capture stage gets its frames: the replay source
// (replay_source.hpp) now, the camera drivers (Aravis, V4L2; the drivers
// issue) later, all behind this interface.
//
// Threads: after construction a source is used by the capture thread only.
// Ownership: the pipeline owns the source (unique_ptr) and destroys it after
// the capture thread has ended.

#include <cstdint>
#include <stop_token>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/pipeline/packets.hpp"

namespace sitepose::pipeline {

enum class SourceEventKind {
  kFrame,    // `frame` holds the next frame
  kTimeout,  // no frame before the deadline (the stream may go on)
  kEnd,      // end of the stream, or a stop was requested
};

struct SourceEvent {
  SourceEventKind kind = SourceEventKind::kEnd;
  StereoFrame frame;  // kFrame only: rectified CV_8UC1 pair, seq and t_ns monotonic
};

// The frame rate to plan with: a source's frame_rate_hz(), or 30 Hz (a
// common camera rate) when it does not know its own (0).
constexpr double kAssumedFrameRateHz = 30.0;
constexpr double known_or_assumed_frame_rate_hz(double frame_rate_hz) {
  return frame_rate_hz > 0.0 ? frame_rate_hz : kAssumedFrameRateHz;
}

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  // Rectified stereo camera of the frames (size included).
  virtual const StereoCamera& camera() const = 0;
  // For logs: "replay /data/seq07 at recorded rate, looping".
  virtual std::string describe() const = 0;
  // Paced by the world (a camera, a replay at the recorded rate)? Then a full
  // ring drops its oldest frame. A source that can wait (a replay as fast as
  // possible) is instead held back by the pipeline (lossless).
  virtual bool live() const = 0;
  // Nominal frame rate (Hz) when known, else 0. The motion-state classifier
  // sizes its look-back by it.
  virtual double frame_rate_hz() const { return 0.0; }

  // Blocks until the next frame, the deadline (kTimeout), the end of the
  // stream (kEnd) or a stop request on `stop` (kEnd, promptly: no frame
  // wait may ignore it). An error means the source failed and cannot go on
  // (a missing file, a device gone); its message names what failed.
  virtual Expected<SourceEvent> next(std::stop_token stop, SteadyTime deadline) = 0;
};

}  // namespace sitepose::pipeline
