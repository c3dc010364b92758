#pragma once
// A detect hook with a deadline (issue 20: a detector that hangs must not
// stop positioning). The wrapped hook (a DetectorStage over a plugin) runs
// on a worker thread of its own; annotate() waits for it at most
// `deadline` (siteposed: dynamic.detector_deadline_ms, default one frame
// period of the source), so the track stage never waits longer than that
// for a frame.
//   * A call that overruns is abandoned and counted (timeouts): the frame
//     goes on undetected, which the track stage handles as for any detector
//     failure (SlamPoseTracker: the last detected boxes while at most
//     kMaxDetectionReuseS old, then unmasked and at most RECOVERING).
//   * While an abandoned call still runs, the detector is busy (a detector
//     is not re-entrant): later frames go on undetected at once (skipped).
//     When the call returns, its late result is dropped (late_returns) and
//     the next frame is detected again.
//   * A call that never returns keeps its worker: the destructor waits
//     `grace` for it, then leaves it (detached, the wrapped hook with it) so
//     that the daemon can still stop; the process ends with it.
// A crash inside the detector (SIGSEGV, abort) cannot be survived in-process;
// siteposed runs a plugin .so in a child process for that
// (detect/isolated_detector.hpp), whose failed calls reach this hook as
// errors like any other.
// Threads: annotate() on the detect thread only; counters() from any thread.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "sitepose/pipeline/hooks.hpp"

namespace sitepose::pipeline {

struct DetectDeadlineCounters {
  std::uint64_t timeouts = 0;      // calls abandoned at the deadline
  std::uint64_t skipped_busy = 0;  // frames not given to a detector still busy with an abandoned call
  std::uint64_t late_returns = 0;  // abandoned calls that returned later (result dropped)
};

class DeadlineDetect final : public DetectHook {
 public:
  DeadlineDetect(std::unique_ptr<DetectHook> inner, std::chrono::nanoseconds deadline,
                 std::chrono::nanoseconds grace = std::chrono::seconds(1));
  ~DeadlineDetect() override;
  DeadlineDetect(const DeadlineDetect&) = delete;
  DeadlineDetect& operator=(const DeadlineDetect&) = delete;

  std::string name() const override { return name_; }
  Status annotate(FramePacket& packet) override;
  DetectDeadlineCounters counters() const;
  std::chrono::nanoseconds deadline() const { return deadline_; }

  struct State;  // shared with the worker, which may outlive this object

 private:
  std::shared_ptr<State> state_;
  const std::string name_;
  const std::chrono::nanoseconds deadline_;
  const std::chrono::nanoseconds grace_;
};

}  // namespace sitepose::pipeline
