#include "sitepose/views/top_view.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string_view>

namespace sitepose::views {
namespace {

std::string literal_pattern(const std::string& channel) {
  // LCM treats the channel as a regular expression; match it literally.
  std::string pattern;
  for (char c : channel) {
    if (std::string_view(".[]{}()\\*+?^$|").find(c) != std::string_view::npos) pattern += '\\';
    pattern += c;
  }
  return pattern;
}

// The message, or nothing when it does not decode as a Message: a message
// on our channel from something else is counted and shown, not fatal.
template <typename Message>
std::optional<Message> decode_or_count(const lcm::ReceiveBuffer& buffer, const std::string& channel,
                                       TopState& state) {
  Message message;
  if (message.decode(buffer.data, 0, static_cast<int>(buffer.data_size)) < 0) {
    ++state.undecodable;
    state.last_error = channel + ": a message that is not a " + Message::getTypeName();
    return std::nullopt;
  }
  return message;
}

const char* state_name(std::int8_t state) {
  switch (state) {
    case sitepose::pose_t::STATE_OK: return "OK";
    case sitepose::pose_t::STATE_RECOVERING: return "RECOVERING";
    case sitepose::pose_t::STATE_LOST: return "LOST";
    default: return "?";
  }
}

const char* state_colour(std::int8_t state) {
  return state == sitepose::pose_t::STATE_OK           ? "\x1b[32m"
         : state == sitepose::pose_t::STATE_RECOVERING ? "\x1b[33m"
                                                       : "\x1b[31m";
}

std::string age(const std::optional<TopClock::time_point>& at, TopClock::time_point now) {
  if (!at) return "never";
  char text[32];
  std::snprintf(text, sizeof text, "%.1f s ago", std::chrono::duration<double>(now - *at).count());
  return text;
}

void health_lines(std::ostringstream& out, const sitepose::health_t& h, bool colour) {
  char line[256];
  std::snprintf(line, sizeof line,
                "rate %.1f frames/s   latency p50 %.1f ms  p99 %.1f ms   captured %lld  tracked %lld  "
                "stalls %lld\n",
                static_cast<double>(h.fps), static_cast<double>(h.latency_p50_ms),
                static_cast<double>(h.latency_p99_ms), static_cast<long long>(h.frames_captured),
                static_cast<long long>(h.frames_tracked), static_cast<long long>(h.stalls));
  out << line;
  out << "tracking " << (colour ? state_colour(h.state) : "") << state_name(h.state)
      << (colour ? "\x1b[0m" : "") << (h.state_reason.empty() ? "" : "  (" + h.state_reason + ")") << "\n\n";
  std::snprintf(line, sizeof line, "%-12s %10s %8s %10s %10s\n", "ring/stage", "drops", "queued", "p50 ms",
                "p99 ms");
  out << line;
  for (int i = 0; i < h.num_stages; ++i) {
    std::snprintf(line, sizeof line, "%-12s %10lld %8d %10.2f %10.2f\n", h.stage_names[i].c_str(),
                  static_cast<long long>(h.drops[i]), h.queue_depths[i], static_cast<double>(h.p50_ms[i]),
                  static_cast<double>(h.p99_ms[i]));
    out << line;
  }
  for (int i = 0; i < h.num_outputs; ++i) {
    std::snprintf(line, sizeof line, "output %-10s errors %lld  failed %lld\n", h.output_names[i].c_str(),
                  static_cast<long long>(h.output_errors[i]), static_cast<long long>(h.output_failed[i]));
    out << line;
  }
}

void pose_lines(std::ostringstream& out, const sitepose::pose_t& p, double rate_hz) {
  char line[256];
  const bool site = p.frame == sitepose::pose_t::FRAME_SITE;
  std::snprintf(line, sizeof line, "pose seq %lld  %s  %.1f Hz   %s position %.3f %.3f %.3f m  +- %.3f m\n",
                static_cast<long long>(p.seq), state_name(p.state), rate_hz,
                site ? "site (E N U)" : "SLAM frame", p.position[0], p.position[1], p.position[2],
                p.position_std_m);
  out << line;
  if (site && std::isfinite(p.latitude_deg)) {
    std::snprintf(line, sizeof line, "  lat %.7f  lon %.7f  h %.2f m   heading %.2f deg\n", p.latitude_deg,
                  p.longitude_deg, p.height_m, p.heading_deg);
    out << line;
  }
  std::snprintf(
      line, sizeof line, "  inliers %d (pass 1: %d)   static objects unmasked %d   masked area %.2f\n",
      p.features_used, p.features_pass1, p.static_objects_unmasked, static_cast<double>(p.masked_area_ratio));
  out << line;
}

}  // namespace

std::string render_top(const TopState& s, TopClock::time_point now, bool colour) {
  std::ostringstream out;
  out << "sitepose top   health " << age(s.health_at, now) << "   pose " << age(s.pose_at, now)
      << "   (q quits)\n\n";
  if (s.health) {
    health_lines(out, *s.health, colour);
  } else {
    out << "no health_t received yet\n";
  }
  out << "\n";
  if (s.pose) {
    pose_lines(out, *s.pose, s.pose_rate_hz);
  } else {
    out << "no pose_t received yet\n";
  }
  out << "\nlast error: " << (s.last_error.empty() ? "-" : s.last_error) << "\n";
  return out.str();
}

Expected<std::unique_ptr<TopMonitor>> TopMonitor::create(std::shared_ptr<lcm::LCM> lcm,
                                                         const std::string& pose_channel,
                                                         const std::string& health_channel) {
  if (!lcm || !lcm->good()) return make_error(ErrorCode::kInvalidArgument, "top: no usable LCM connection");
  std::unique_ptr<TopMonitor> monitor(new TopMonitor(std::move(lcm)));
  monitor->pose_subscription_ =
      monitor->lcm_->subscribe(literal_pattern(pose_channel), &TopMonitor::on_pose, monitor.get());
  monitor->health_subscription_ =
      monitor->lcm_->subscribe(literal_pattern(health_channel), &TopMonitor::on_health, monitor.get());
  if (monitor->pose_subscription_ == nullptr || monitor->health_subscription_ == nullptr) {
    return make_error(ErrorCode::kIoError,
                      "LCM: cannot subscribe to " + pose_channel + " and " + health_channel);
  }
  return monitor;
}

TopMonitor::~TopMonitor() {
  if (pose_subscription_ != nullptr) lcm_->unsubscribe(pose_subscription_);
  if (health_subscription_ != nullptr) lcm_->unsubscribe(health_subscription_);
}

bool TopMonitor::handle(int timeout_ms) { return lcm_->handleTimeout(timeout_ms) >= 0; }

void TopMonitor::on_pose(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  std::optional<sitepose::pose_t> decoded = decode_or_count<sitepose::pose_t>(*buffer, channel, state_);
  if (!decoded) return;
  sitepose::pose_t& pose = *decoded;
  const auto now = TopClock::now();
  pose_times_.push_back(now);
  while (pose_times_.size() > 1 && now - pose_times_.front() > std::chrono::seconds(2))
    pose_times_.pop_front();
  const double span_s = std::chrono::duration<double>(pose_times_.back() - pose_times_.front()).count();
  state_.pose_rate_hz = span_s > 0 ? (pose_times_.size() - 1) / span_s : 0.0;
  if (!pose.state_reason.empty()) state_.last_error = "pose: " + pose.state_reason;
  state_.pose = std::move(pose);
  state_.pose_at = now;
  ++state_.poses_received;
}

void TopMonitor::on_health(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  std::optional<sitepose::health_t> decoded = decode_or_count<sitepose::health_t>(*buffer, channel, state_);
  if (!decoded) return;
  sitepose::health_t& health = *decoded;
  if (!health.state_reason.empty()) state_.last_error = "health: " + health.state_reason;
  state_.health = std::move(health);
  state_.health_at = TopClock::now();
  ++state_.healths_received;
}

}  // namespace sitepose::views
