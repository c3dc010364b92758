#include "sitepose/pipeline/replay_source.hpp"

#include <algorithm>

namespace sitepose::pipeline {

Expected<ReplayRate> parse_replay_rate(const std::string& name) {
  if (name == "recorded") return ReplayRate::kRecorded;
  if (name == "max") return ReplayRate::kMax;
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown replay rate \"" + name + "\" (expected one of: recorded, max)");
}

const char* to_string(ReplayRate rate) { return rate == ReplayRate::kRecorded ? "recorded" : "max"; }

Expected<std::unique_ptr<ReplaySource>> ReplaySource::open(const ReplayOptions& options) {
  if (options.max_frames < 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "replay max_frames = " + std::to_string(options.max_frames) + ": must be >= 0");
  }
  io::SequenceOptions sequence_options;
  sequence_options.channel_order = options.channel_order;
  SITEPOSE_TRY(auto sequence, io::open_sequence(options.sequence_dir, sequence_options));
  if (sequence->size() == 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "replay sequence " + options.sequence_dir + ": has no frames");
  }
  return std::unique_ptr<ReplaySource>(new ReplaySource(options, std::move(sequence)));
}

ReplaySource::ReplaySource(const ReplayOptions& options, std::unique_ptr<io::Sequence> sequence)
    : options_(options), sequence_(std::move(sequence)) {
  frames_per_pass_ = options_.max_frames > 0 ? std::min<std::size_t>(options_.max_frames, sequence_->size())
                                             : sequence_->size();
  const std::int64_t t0 = sequence_->time_ns(0);
  const std::int64_t duration = sequence_->time_ns(frames_per_pass_ - 1) - t0;
  const std::int64_t mean_interval =
      frames_per_pass_ > 1 ? duration / static_cast<std::int64_t>(frames_per_pass_ - 1) : 100'000'000;
  pass_period_ns_ = duration + std::max<std::int64_t>(mean_interval, 1);
  frame_rate_hz_ = io::mean_frame_rate_hz(*sequence_, frames_per_pass_);
}

std::string ReplaySource::describe() const {
  return "replay " + sequence_->directory() + " (" + std::to_string(frames_per_pass_) + " frames) at " +
         (options_.rate == ReplayRate::kRecorded ? "the recorded rate" : "max rate") +
         (options_.loop ? ", looping" : "");
}

Expected<SourceEvent> ReplaySource::next(std::stop_token stop, SteadyTime deadline) {
  if (stop.stop_requested()) return SourceEvent{SourceEventKind::kEnd, {}};
  if (!options_.loop && next_index_ >= frames_per_pass_) return SourceEvent{SourceEventKind::kEnd, {}};
  const std::size_t pass = next_index_ / frames_per_pass_;
  const std::size_t index = next_index_ % frames_per_pass_;
  const std::int64_t shift_ns = static_cast<std::int64_t>(pass) * pass_period_ns_;
  const std::int64_t t_ns = sequence_->time_ns(index) + shift_ns;
  if (options_.rate == ReplayRate::kRecorded) {
    if (!started_) {
      started_ = true;
      start_ = SteadyClock::now();
    }
    const SteadyTime due = start_ + std::chrono::nanoseconds(t_ns - sequence_->time_ns(0));
    std::unique_lock lock(wait_mutex_);
    // Wakes on a stop request; otherwise sleeps to the due time or the deadline.
    wait_cv_.wait_until(lock, stop, std::min(due, deadline), [] { return false; });
    if (stop.stop_requested()) return SourceEvent{SourceEventKind::kEnd, {}};
    if (SteadyClock::now() < due) return SourceEvent{SourceEventKind::kTimeout, {}};
  }
  SITEPOSE_TRY(StereoFrame frame, sequence_->read_frame(index));
  frame.seq = static_cast<std::int64_t>(next_index_);
  frame.t_left_ns += shift_ns;
  frame.t_right_ns += shift_ns;
  ++next_index_;
  return SourceEvent{SourceEventKind::kFrame, std::move(frame)};
}

}  // namespace sitepose::pipeline
