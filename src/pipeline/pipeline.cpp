#include "sitepose/pipeline/pipeline.hpp"

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "sitepose/core/log.hpp"

namespace sitepose::pipeline {
namespace {

std::int64_t to_ns(SteadyClock::duration d) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}
double to_ms(SteadyClock::duration d) { return static_cast<double>(to_ns(d)) * 1e-6; }
SteadyClock::duration seconds(double s) {
  return std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(s));
}

void name_this_thread(const char* name) {
  // Shown by top -H, gdb and the journal; 15 characters at most.
  pthread_setname_np(pthread_self(), name);
}

// Repeated warnings: the first few, then one in a hundred (STYLE.md §7).
bool should_log(std::uint64_t count) { return count <= 5 || count % 100 == 0; }

}  // namespace

Status check_pipeline_options(const PipelineOptions& o, const std::string& prefix) {
  std::string problems;
  auto add = [&](const std::string& text) {
    if (!problems.empty()) problems += "\n";
    problems += text;
  };
  for (auto [key, capacity] : {std::pair{"capture_ring_capacity", o.capture_ring_capacity},
                               std::pair{"detect_ring_capacity", o.detect_ring_capacity},
                               std::pair{"publish_ring_capacity", o.publish_ring_capacity}}) {
    if (auto st = check_ring_capacity(prefix + "." + key, capacity); !st) add(st.error().message);
  }
  auto number = [](double v) {
    std::string s = std::to_string(v);
    return s;
  };
  if (!(o.stall_timeout_s >= 0.05 && o.stall_timeout_s <= 3600.0)) {
    add(prefix + ".stall_timeout_s = " + number(o.stall_timeout_s) + ": must be in [0.05, 3600]");
  }
  if (o.publish_max_attempts < 1 || o.publish_max_attempts > 100) {
    add(prefix + ".publish_max_attempts = " + std::to_string(o.publish_max_attempts) +
        ": must be in [1, 100]");
  }
  if (!(o.publish_retry_delay_s >= 0.0 && o.publish_retry_delay_s <= 1.0)) {
    add(prefix + ".publish_retry_delay_s = " + number(o.publish_retry_delay_s) + ": must be in [0, 1]");
  }
  if (!(o.health_interval_s >= 0.05 && o.health_interval_s <= 3600.0)) {
    add(prefix + ".health_interval_s = " + number(o.health_interval_s) + ": must be in [0.05, 3600]");
  }
  if (!problems.empty()) return make_error(ErrorCode::kInvalidArgument, problems);
  return ok_status();
}

Expected<std::unique_ptr<Pipeline>> Pipeline::create(const PipelineOptions& options,
                                                     std::unique_ptr<FrameSource> source,
                                                     std::unique_ptr<DetectHook> detect,
                                                     std::unique_ptr<PoseTracker> tracker,
                                                     std::vector<std::unique_ptr<PoseOutput>> outputs) {
  SITEPOSE_TRY_STATUS(check_pipeline_options(options));
  if (!source || !detect || !tracker) {
    return make_error(ErrorCode::kInvalidArgument,
                      "pipeline: a source, a detect hook and a tracker are required");
  }
  for (const auto& output : outputs) {
    if (!output) return make_error(ErrorCode::kInvalidArgument, "pipeline: an output is null");
  }
  return std::unique_ptr<Pipeline>(
      new Pipeline(options, std::move(source), std::move(detect), std::move(tracker), std::move(outputs)));
}

Pipeline::Pipeline(const PipelineOptions& options, std::unique_ptr<FrameSource> source,
                   std::unique_ptr<DetectHook> detect, std::unique_ptr<PoseTracker> tracker,
                   std::vector<std::unique_ptr<PoseOutput>> outputs)
    : options_(options),
      overflow_(source->live() ? OverflowPolicy::kDropOldest : OverflowPolicy::kBlock),
      created_(SteadyClock::now()),
      source_(std::move(source)),
      detect_(std::move(detect)),
      tracker_(std::move(tracker)),
      to_detect_(options.capture_ring_capacity, overflow_),
      to_track_(options.detect_ring_capacity, overflow_),
      to_publish_(options.publish_ring_capacity, overflow_) {
  for (auto& output : outputs) {
    auto slot = std::make_unique<OutputSlot>();
    slot->name = output->name();
    slot->output = std::move(output);
    outputs_.push_back(std::move(slot));
  }
}

Pipeline::~Pipeline() {
  stop();
  // jthread members join in reverse order of declaration: publish first
  // would wait for track; request_stop()/join() order does not matter since
  // stop() has released every blocking point.
  (void)wait();
}

void Pipeline::start() {
  if (started_.exchange(true)) return;
  // Consumers first, so nothing waits on a thread that does not exist yet.
  publish_thread_ = std::jthread([this] { publish_loop(); });
  track_thread_ = std::jthread([this](const std::stop_token& st) { track_loop(st); });
  detect_thread_ = std::jthread([this](const std::stop_token& st) { detect_loop(st); });
  capture_thread_ = std::jthread([this](const std::stop_token& st) { capture_loop(st); });
}

void Pipeline::stop() {
  if (stop_requested_.exchange(true)) return;
  capture_thread_.request_stop();
  detect_thread_.request_stop();
  track_thread_.request_stop();
  // Release producers blocked on a full lossless link; the publish link is
  // drained by its consumer, so its producer never stays blocked.
  to_detect_.wake_producer();
  to_track_.wake_producer();
}

Status Pipeline::wait() {
  for (std::jthread* t : {&capture_thread_, &detect_thread_, &track_thread_, &publish_thread_}) {
    if (t->joinable()) t->join();
  }
  std::lock_guard lock(mutex_);
  return source_status_;
}

void Pipeline::capture_loop(const std::stop_token& stop) {
  name_this_thread("sp-capture");
  SteadyTime last_frame = SteadyClock::now();
  while (!stop.stop_requested()) {
    const SteadyTime asked = SteadyClock::now();
    auto event = source_->next(stop, asked + seconds(options_.stall_timeout_s));
    const SteadyTime now = SteadyClock::now();
    if (!event) {
      spdlog::error("capture: source failed: {}", event.error().message);
      std::lock_guard lock(mutex_);
      source_status_ = Unexpected{event.error()};
      break;
    }
    if (event->kind == SourceEventKind::kEnd) break;
    FramePacket packet;
    packet.captured = now;
    if (event->kind == SourceEventKind::kTimeout) {
      packet.kind = PacketKind::kStall;
      packet.stall_ns = to_ns(now - last_frame);
      const std::uint64_t n = stalls_.fetch_add(1, std::memory_order_relaxed) + 1;
      if (should_log(n)) {
        spdlog::warn("capture: source stalled, no frame for {:.2f} s (stall report {})",
                     packet.stall_ns * 1e-9, n);
      }
    } else {
      packet.frame = std::move(event->frame);
      last_frame = now;
      frames_captured_.fetch_add(1, std::memory_order_relaxed);
      capture_stats_.time.record_ms(to_ms(now - asked));
    }
    capture_stats_.items.fetch_add(1, std::memory_order_relaxed);
    to_detect_.push(std::move(packet));
  }
  source_ended_.store(true, std::memory_order_release);
  to_detect_.close();
  thread_done();
}

void Pipeline::detect_loop(const std::stop_token& stop) {
  name_this_thread("sp-detect");
  while (auto packet = to_detect_.pop()) {
    const SteadyTime t0 = SteadyClock::now();
    if (packet->kind == PacketKind::kFrame) {
      if (auto st = detect_->annotate(*packet); !st) {
        const std::uint64_t n = detect_errors_.fetch_add(1, std::memory_order_relaxed) + 1;
        if (should_log(n)) {
          spdlog::warn("detect: {} failed on seq={} ({} errors so far): {}", detect_->name(),
                       packet->frame.seq, n, st.error().message);
        }
      }
    }
    detect_stats_.time.record_ms(to_ms(SteadyClock::now() - t0));
    detect_stats_.items.fetch_add(1, std::memory_order_relaxed);
    to_track_.push(std::move(*packet));
    if (stop.stop_requested()) break;
  }
  if (stop.stop_requested()) {
    discarded_at_stop_.fetch_add(to_detect_.discard(), std::memory_order_relaxed);
  }
  to_track_.close();
  thread_done();
}

void Pipeline::record_track_rate(SteadyTime now) {
  const std::int64_t now_ns = to_ns(now - created_);
  const std::int64_t last = last_track_ns_.exchange(now_ns, std::memory_order_relaxed);
  if (last == 0) return;
  const std::int64_t interval = now_ns - last;
  const std::int64_t avg = track_interval_ns_.load(std::memory_order_relaxed);
  // EWMA over ~8 frames: steady figures, yet a rate change shows in a second.
  track_interval_ns_.store(avg == 0 ? interval : avg + (interval - avg) / 8, std::memory_order_relaxed);
}

void Pipeline::track_loop(const std::stop_token& stop) {
  name_this_thread("sp-track");
  PoseEstimate last_pose;  // LOST, identity: what a stall before any frame repeats
  last_pose.state_reason = "no frame yet";
  while (auto packet = to_track_.pop()) {
    const SteadyTime t0 = SteadyClock::now();
    PosePacket out;
    out.captured = packet->captured;
    if (packet->kind == PacketKind::kStall) {
      out.from_stall = true;
      out.pose.seq = last_pose.seq;
      out.pose.t_ns = last_pose.t_ns + packet->stall_ns;
      out.pose.T_world_cam = last_pose.T_world_cam;
      out.pose.covariance = last_pose.covariance;
      out.pose.map_travel_m = last_pose.map_travel_m;
      out.pose.state = TrackingState::kLost;
      out.pose.state_reason =
          "source stalled: no frame for " + std::to_string(packet->stall_ns / 1'000'000) + " ms";
    } else {
      auto pose = tracker_->track(*packet);
      if (pose) {
        out.pose = std::move(*pose);
      } else {
        const std::uint64_t n = track_errors_.fetch_add(1, std::memory_order_relaxed) + 1;
        if (should_log(n)) {
          spdlog::warn("track: frame seq={} rejected ({} so far): {}", packet->frame.seq, n,
                       pose.error().message);
        }
        out.pose.seq = packet->frame.seq;
        out.pose.t_ns = packet->frame.t_ns();
        out.pose.T_world_cam = last_pose.T_world_cam;
        out.pose.state = TrackingState::kLost;
        out.pose.state_reason = "frame rejected: " + pose.error().message;
      }
      last_pose = out.pose;
      frames_tracked_.fetch_add(1, std::memory_order_relaxed);
      record_track_rate(SteadyClock::now());
    }
    track_stats_.time.record_ms(to_ms(SteadyClock::now() - t0));
    track_stats_.items.fetch_add(1, std::memory_order_relaxed);
    to_publish_.push(std::move(out));
    if (stop.stop_requested()) break;
  }
  if (stop.stop_requested()) {
    discarded_at_stop_.fetch_add(to_track_.discard(), std::memory_order_relaxed);
  }
  tracker_->finish();
  to_publish_.close();
  thread_done();
}

void Pipeline::publish_to(OutputSlot& slot, const PosePacket& packet) {
  Status st = slot.output->publish(packet);
  int attempts = 1;
  while (!st) {
    const std::uint64_t n = slot.errors.fetch_add(1, std::memory_order_relaxed) + 1;
    if (should_log(n)) {
      spdlog::warn("publish: {} failed on seq={} (attempt {}/{}, {} errors so far): {}", slot.name,
                   packet.pose.seq, attempts, options_.publish_max_attempts, n, st.error().message);
    }
    if (attempts >= options_.publish_max_attempts) {
      slot.failed.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    // A short back-off, not a poll: the link (bus, socket) may need a moment
    // to drain; the ring behind absorbs the delay or drops its oldest.
    if (options_.publish_retry_delay_s > 0.0) {
      std::this_thread::sleep_for(seconds(options_.publish_retry_delay_s));
    }
    slot.retries.fetch_add(1, std::memory_order_relaxed);
    st = slot.output->retry();
    ++attempts;
  }
  slot.published.fetch_add(1, std::memory_order_relaxed);
}

void Pipeline::publish_health_to_outputs() {
  const PipelineHealth snapshot = health();
  for (auto& slot : outputs_) {
    if (auto st = slot->output->publish_health(snapshot); !st) {
      const std::uint64_t n = slot->health_errors.fetch_add(1, std::memory_order_relaxed) + 1;
      if (should_log(n)) spdlog::warn("publish: {} health report failed: {}", slot->name, st.error().message);
    }
  }
}

void Pipeline::publish_loop() {
  name_this_thread("sp-publish");
  last_health_published_ = SteadyClock::now();
  while (auto packet = to_publish_.pop()) {
    const SteadyTime t0 = SteadyClock::now();
    for (auto& slot : outputs_) publish_to(*slot, *packet);
    const SteadyTime done = SteadyClock::now();
    if (!packet->from_stall) latency_.record_ms(to_ms(done - packet->captured));
    {
      std::lock_guard lock(mutex_);
      last_state_ = packet->pose.state;
      last_reason_ = packet->pose.state_reason;
    }
    poses_published_.fetch_add(1, std::memory_order_relaxed);
    publish_stats_.time.record_ms(to_ms(done - t0));
    publish_stats_.items.fetch_add(1, std::memory_order_relaxed);
    if (done - last_health_published_ >= seconds(options_.health_interval_s)) {
      last_health_published_ = done;
      publish_health_to_outputs();
    }
  }
  thread_done();  // counted before the final report, so it says "not running"
  publish_health_to_outputs();
}

PipelineHealth Pipeline::health() const {
  PipelineHealth h;
  const SteadyTime now = SteadyClock::now();
  h.uptime_ns = to_ns(now - created_);
  h.running = started_.load(std::memory_order_acquire) && !finished();
  h.source_ended = source_ended_.load(std::memory_order_acquire);
  h.frames_captured = frames_captured_.load(std::memory_order_relaxed);
  h.frames_tracked = frames_tracked_.load(std::memory_order_relaxed);
  h.stalls = stalls_.load(std::memory_order_relaxed);
  h.detect_errors = detect_errors_.load(std::memory_order_relaxed);
  h.track_errors = track_errors_.load(std::memory_order_relaxed);
  h.discarded_at_stop = discarded_at_stop_.load(std::memory_order_relaxed);
  h.poses_published = poses_published_.load(std::memory_order_relaxed);
  const std::int64_t interval = track_interval_ns_.load(std::memory_order_relaxed);
  const std::int64_t since_last = h.uptime_ns - last_track_ns_.load(std::memory_order_relaxed);
  // No frame for two intervals (and at least a second): nothing flows.
  if (interval > 0 && since_last <= std::max<std::int64_t>(2 * interval, 1'000'000'000)) {
    h.fps = 1e9 / static_cast<double>(interval);
  }
  h.latency_p50_ms = latency_.percentile_ms(0.5);
  h.latency_p99_ms = latency_.percentile_ms(0.99);
  {
    std::lock_guard lock(mutex_);
    h.state = last_state_;
    h.state_reason = last_reason_;
  }
  auto stage = [](const char* name, const StageStats& s, std::uint64_t drops, std::uint64_t depth) {
    return StageHealth{name,
                       s.items.load(std::memory_order_relaxed),
                       drops,
                       depth,
                       s.time.percentile_ms(0.5),
                       s.time.percentile_ms(0.99)};
  };
  h.stages.push_back(stage("capture", capture_stats_, 0, 0));
  h.stages.push_back(stage("detect", detect_stats_, to_detect_.drops(), to_detect_.depth()));
  h.stages.push_back(stage("track", track_stats_, to_track_.drops(), to_track_.depth()));
  h.stages.push_back(stage("publish", publish_stats_, to_publish_.drops(), to_publish_.depth()));
  for (const auto& slot : outputs_) {
    h.outputs.push_back(OutputHealth{
        slot->name, slot->published.load(std::memory_order_relaxed),
        slot->errors.load(std::memory_order_relaxed), slot->retries.load(std::memory_order_relaxed),
        slot->failed.load(std::memory_order_relaxed), slot->health_errors.load(std::memory_order_relaxed)});
  }
  return h;
}

}  // namespace sitepose::pipeline
