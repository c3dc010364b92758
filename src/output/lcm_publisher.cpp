#include "sitepose/output/lcm_publisher.hpp"

#include <fmt/format.h>

namespace sitepose::output {

Expected<std::unique_ptr<LcmPublisher>> LcmPublisher::create(const LcmOptions& options,
                                                             std::shared_ptr<lcm::LCM> lcm) {
  SITEPOSE_TRY_STATUS(options.validate());
  if (!lcm || !lcm->good()) {
    return make_error(ErrorCode::kInvalidArgument, "LcmPublisher: no usable lcm::LCM instance");
  }
  lcm::LCM* raw = lcm.get();
  SendFn send = [raw](const std::string& channel, const void* data, unsigned size) {
    return raw->publish(channel, data, size);
  };
  return std::unique_ptr<LcmPublisher>(new LcmPublisher(options, std::move(send), std::move(lcm)));
}

Expected<std::unique_ptr<LcmPublisher>> LcmPublisher::create_with_sender(const LcmOptions& options,
                                                                         SendFn send) {
  SITEPOSE_TRY_STATUS(options.validate());
  if (!send) return make_error(ErrorCode::kInvalidArgument, "LcmPublisher: empty send function");
  return std::unique_ptr<LcmPublisher>(new LcmPublisher(options, std::move(send), nullptr));
}

Status LcmPublisher::publish_pose(const PoseEstimate& pose, const geo::SitePose* site,
                                  const Velocity* velocity, const IntegrityOptions& integrity) {
  SITEPOSE_TRY(std::vector<std::uint8_t> bytes, encode_lcm(to_lcm_pose(pose, site, velocity, integrity)));
  return send({options_.pose_channel, std::move(bytes), true});
}

Status LcmPublisher::publish_health(const LcmHealth& health) {
  SITEPOSE_TRY(std::vector<std::uint8_t> bytes, encode_lcm(to_lcm_health(health)));
  return send({options_.health_channel, std::move(bytes), false});
}

Status LcmPublisher::retry_pose() {
  if (pending_pose_.bytes.empty()) return ok_status();
  Message message = std::move(pending_pose_);
  pending_pose_ = Message{};
  return send(std::move(message));
}

Status LcmPublisher::send(Message message) {
  // A new pose supersedes an unsent one: the newest pose matters most.
  if (message.is_pose) pending_pose_ = Message{};
  for (int attempt = 0; attempt < options_.max_send_attempts; ++attempt) {
    if (attempt > 0) retries_.fetch_add(1, std::memory_order_relaxed);
    const int rc = send_(message.channel, message.bytes.data(), static_cast<unsigned>(message.bytes.size()));
    if (rc == 0) {
      (message.is_pose ? poses_published_ : health_published_).fetch_add(1, std::memory_order_relaxed);
      return ok_status();
    }
    send_failures_.fetch_add(1, std::memory_order_relaxed);
  }
  messages_failed_.fetch_add(1, std::memory_order_relaxed);
  const std::string channel = message.channel;
  const std::size_t size = message.bytes.size();
  if (message.is_pose) pending_pose_ = std::move(message);
  return make_error(ErrorCode::kIoError, fmt::format("LCM publish on {} ({} bytes) failed {} time(s)",
                                                     channel, size, options_.max_send_attempts));
}

LcmPublisherStats LcmPublisher::stats() const {
  LcmPublisherStats s;
  s.poses_published = poses_published_.load(std::memory_order_relaxed);
  s.health_published = health_published_.load(std::memory_order_relaxed);
  s.send_failures = send_failures_.load(std::memory_order_relaxed);
  s.retries = retries_.load(std::memory_order_relaxed);
  s.messages_failed = messages_failed_.load(std::memory_order_relaxed);
  return s;
}

}  // namespace sitepose::output
