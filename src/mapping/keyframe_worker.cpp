#include "sitepose/mapping/keyframe_worker.hpp"

#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "sitepose/core/log.hpp"

namespace sitepose::mapping {

KeyFrameWorker::KeyFrameWorker(KeyFrameWorkerOptions options, Process process)
    : options_(std::move(options)), process_(std::move(process)) {}

KeyFrameWorker::~KeyFrameWorker() { stop(); }

void KeyFrameWorker::enqueue(map::KeyFrameId keyframe) {
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(keyframe);
    interrupt_.store(true);
  }
  queue_cv_.notify_one();
}

Status KeyFrameWorker::process_pending() {
  Status first_error;
  for (;;) {
    map::KeyFrameId id = map::kNoKeyFrame;
    {
      std::lock_guard lock(mutex_);
      if (queue_.empty()) break;
      id = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    Status status = process_(id);
    {
      std::lock_guard lock(mutex_);
      busy_ = false;
    }
    if (!status && first_error) first_error = std::move(status);
  }
  idle_cv_.notify_all();
  return first_error;
}

void KeyFrameWorker::start() {
  if (running_.load()) return;
  running_.store(true);
  thread_ = std::jthread([this](const std::stop_token& stop_token) { run(stop_token); });
  pthread_setname_np(thread_.native_handle(), options_.thread_name.c_str());
}

void KeyFrameWorker::stop() {
  if (!thread_.joinable()) return;
  interrupt_.store(true);
  thread_.request_stop();  // wakes the condition_variable_any wait
  thread_.join();
  thread_ = std::jthread();
  {
    // Under the lock so a waiter cannot miss the change between its test and its wait.
    std::lock_guard lock(mutex_);
    running_.store(false);
  }
  idle_cv_.notify_all();
}

bool KeyFrameWorker::running() const { return running_.load(); }

void KeyFrameWorker::run(const std::stop_token& stop_token) {
  // Raising a thread's own nice value needs no privilege; failure is harmless.
  if (setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), options_.nice) != 0) {
    spdlog::debug("{}: could not lower the thread's priority: {}", options_.log_name, std::strerror(errno));
  }
  while (!stop_token.stop_requested()) {
    map::KeyFrameId id = map::kNoKeyFrame;
    {
      std::unique_lock lock(mutex_);
      if (!queue_cv_.wait(lock, stop_token, [this] { return !queue_.empty() && holds_ == 0; })) break;
      id = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    const Status status = process_(id);
    if (!status) spdlog::warn("{}: keyframe={} {}", options_.log_name, id, status.error().message);
    {
      std::lock_guard lock(mutex_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void KeyFrameWorker::hold() {
  std::unique_lock lock(mutex_);
  ++holds_;
  interrupt_.store(true);
  idle_cv_.wait(lock, [this] { return !running_.load() || !busy_; });
}

void KeyFrameWorker::release() {
  {
    std::lock_guard lock(mutex_);
    if (holds_ > 0) --holds_;
  }
  queue_cv_.notify_one();
}

void KeyFrameWorker::wait_until_idle() {
  std::unique_lock lock(mutex_);
  idle_cv_.wait(lock, [this] { return !running_.load() || (queue_.empty() && !busy_); });
}

bool KeyFrameWorker::idle() const {
  std::lock_guard lock(mutex_);
  return queue_.empty() && !busy_;
}

bool KeyFrameWorker::busy() const {
  std::lock_guard lock(mutex_);
  return busy_;
}

std::size_t KeyFrameWorker::queue_size() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

bool KeyFrameWorker::begin_interruptible_step() {
  std::lock_guard lock(mutex_);
  if (!queue_.empty() || holds_ > 0) return false;
  interrupt_.store(false);
  return true;
}

}  // namespace sitepose::mapping
