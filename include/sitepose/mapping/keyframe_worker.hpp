#pragma once
// The keyframe queue of a background stage and the one thread that serves
// it (the local mapper's, the loop closer's). Keyframes are processed one
// at a time, in order, either
//   * on the worker thread: start() runs it, named (top, gdb, perf) and at
//     a lowered priority, waiting on a condition variable for keyframes;
//     stop() ends it after the keyframe in progress, the rest stay queued;
//   * or on the caller's thread: process_pending() (deterministic runs),
//     never while the thread runs.
// hold() stops the thread taking keyframes until release() (the loop
// closer's pause of the mapper, ORB-SLAM2 RequestStop / Release, and the
// tracker's while it joins a provisional map); holds nest.
//
// Threading: start(), stop() and the destructor belong to the owner's
// thread; every other member may be called from any thread. `process` is
// called with no lock held; a failure on the thread is logged, and the
// thread goes on with the next keyframe.

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <stop_token>
#include <string>
#include <thread>

#include "sitepose/core/expected.hpp"
#include "sitepose/map/map_types.hpp"

namespace sitepose::mapping {

struct KeyFrameWorkerOptions {
  std::string thread_name;  // at most 15 characters (the kernel's limit)
  // Nice value of the thread (0 = the tracking threads'): background work
  // must not delay a frame on a small onboard computer (2 cores).
  int nice = 0;
  std::string log_name;  // names the stage in log lines ("local mapping")
};

class KeyFrameWorker {
 public:
  using Process = std::function<Status(map::KeyFrameId)>;

  KeyFrameWorker(KeyFrameWorkerOptions options, Process process);
  ~KeyFrameWorker();
  KeyFrameWorker(const KeyFrameWorker&) = delete;
  KeyFrameWorker& operator=(const KeyFrameWorker&) = delete;

  void start();
  // Raises the interrupt flag and ends the thread after the keyframe in progress.
  void stop();
  bool running() const;

  // Queues a keyframe and raises the interrupt flag.
  void enqueue(map::KeyFrameId keyframe);

  // Processes all queued keyframes on the calling thread; returns the first
  // error (the rest of the queue is still processed). The thread must not run.
  Status process_pending();

  // Raises the interrupt flag and returns once the keyframe in progress is
  // finished; no further keyframe is taken until every hold() is
  // release()d (two holders cannot end each other's hold). enqueue() still
  // queues. No effect on process_pending().
  void hold();
  void release();

  // Blocks until the queue is empty and no keyframe is in progress; returns
  // at once when the thread is not running.
  void wait_until_idle();
  // No keyframe queued or in progress.
  bool idle() const;
  // A keyframe in progress.
  bool busy() const;
  std::size_t queue_size() const;

  // Raised when something more urgent than the keyframe in progress comes
  // (a newer keyframe, a hold, a stop); a long step polls it to end early
  // (ORB-SLAM2 InterruptBA).
  std::atomic<bool>& interrupt() { return interrupt_; }
  // Before such a step: clears the flag and returns true when no keyframe
  // waits and the worker is not held, else false (skip the step). Under the
  // queue lock, so an enqueue() or hold() after it raises the flag again.
  bool begin_interruptible_step();

 private:
  void run(const std::stop_token& stop_token);

  KeyFrameWorkerOptions options_;
  Process process_;

  mutable std::mutex mutex_;
  std::condition_variable_any queue_cv_;  // guarded by mutex_: keyframe queued or hold released
  std::condition_variable idle_cv_;       // guarded by mutex_: became idle
  std::deque<map::KeyFrameId> queue_;     // guarded by mutex_
  bool busy_ = false;                     // guarded by mutex_
  int holds_ = 0;                         // guarded by mutex_: hold() calls not yet released
  std::atomic<bool> interrupt_{false};
  std::atomic<bool> running_{false};
  std::jthread thread_;  // owner's thread only
};

}  // namespace sitepose::mapping
