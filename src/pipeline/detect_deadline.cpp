#include "sitepose/pipeline/detect_deadline.hpp"

#include <pthread.h>

#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>

namespace sitepose::pipeline {

// Owned jointly by the hook and its worker: a worker stuck in a detector
// call keeps it (and the detector) alive after the hook is gone.
struct DeadlineDetect::State {
  std::mutex mutex;
  std::condition_variable wake;  // the worker: a job or quit
  std::condition_variable done;  // annotate(): the job's result
  std::unique_ptr<DetectHook> inner;
  std::optional<FramePacket> job;  // handed to the worker
  std::uint64_t job_id = 0;        // of the last job handed over
  bool busy = false;               // the worker is in a call
  std::uint64_t result_id = 0;     // of the last result
  std::uint64_t abandoned_id = 0;  // of the last job abandoned at its deadline
  FramePacket result;
  Status result_status;
  bool quit = false;
  DetectDeadlineCounters counters;
};

namespace {

void worker_loop(const std::shared_ptr<DeadlineDetect::State>& s) {
  pthread_setname_np(pthread_self(), "sp-detector");
  std::unique_lock lock(s->mutex);
  for (;;) {
    s->wake.wait(lock, [&] { return s->quit || s->job; });
    if (!s->job) return;  // quit with nothing to do
    FramePacket packet = std::move(*s->job);
    s->job.reset();
    const std::uint64_t id = s->job_id;
    lock.unlock();
    Status st = s->inner->annotate(packet);
    lock.lock();
    s->busy = false;
    if (s->abandoned_id == id) ++s->counters.late_returns;
    s->result_id = id;
    s->result = std::move(packet);
    s->result_status = std::move(st);
    s->done.notify_all();
  }
}

}  // namespace

DeadlineDetect::DeadlineDetect(std::unique_ptr<DetectHook> inner, std::chrono::nanoseconds deadline,
                               std::chrono::nanoseconds grace)
    : state_(std::make_shared<State>()), name_(inner->name()), deadline_(deadline), grace_(grace) {
  state_->inner = std::move(inner);
  std::thread([s = state_] { worker_loop(s); }).detach();
}

DeadlineDetect::~DeadlineDetect() {
  std::unique_lock lock(state_->mutex);
  state_->quit = true;
  state_->wake.notify_all();
  // An idle worker ends at once; a busy one gets `grace` to return. Either
  // way it holds its own reference to the state, so nothing it touches goes.
  if (!state_->done.wait_for(lock, grace_, [&] { return !state_->busy; })) return;
  // Idle: the worker will not touch the detector again; unload it here.
  std::unique_ptr<DetectHook> inner = std::move(state_->inner);
  lock.unlock();
}

Status DeadlineDetect::annotate(FramePacket& packet) {
  packet.detected = false;
  packet.objects.clear();
  packet.instance_mask = cv::Mat();
  std::unique_lock lock(state_->mutex);
  if (state_->busy) {
    ++state_->counters.skipped_busy;
    return make_error(ErrorCode::kRuntime,
                      "detector still busy with a call abandoned at its deadline: frame skipped");
  }
  // The worker's copy shares the pixels (read-only once captured).
  state_->job = packet;
  const std::uint64_t id = ++state_->job_id;
  state_->busy = true;
  state_->wake.notify_all();
  const bool returned = state_->done.wait_for(lock, deadline_, [&] { return state_->result_id == id; });
  if (!returned) {
    ++state_->counters.timeouts;
    state_->abandoned_id = id;
    return make_error(ErrorCode::kRuntime,
                      fmt::format("detector call exceeded its deadline of {:.1f} ms: abandoned",
                                  std::chrono::duration<double, std::milli>(deadline_).count()));
  }
  packet.detected = state_->result.detected;
  packet.objects = std::move(state_->result.objects);
  packet.instance_mask = std::move(state_->result.instance_mask);
  return state_->result_status;
}

DetectDeadlineCounters DeadlineDetect::counters() const {
  std::lock_guard lock(state_->mutex);
  return state_->counters;
}

}  // namespace sitepose::pipeline
