#pragma once
// Publishing poses and health over LCM (pose_t, health_t).
//
// Failures never throw: a send that fails is retried at once, up to
// max_send_attempts in all, then the call returns kIoError. A pose that
// failed is kept so that retry_pose() can send it again later (the daemon's
// publish stage retries a failed output with a delay: PoseOutput::retry());
// a newer pose replaces it. Health is not kept: the next report supersedes
// it. Every failed attempt is counted.
// Threads: an LcmPublisher is used from one thread (the publish stage);
// stats() may be read from any thread.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/geo/site_frame.hpp"
#include "sitepose/output/lcm_bus.hpp"
#include "sitepose/output/lcm_messages.hpp"

namespace sitepose::output {

struct LcmPublisherStats {
  std::int64_t poses_published = 0;
  std::int64_t health_published = 0;
  std::int64_t send_failures = 0;    // failed attempts, retries included
  std::int64_t retries = 0;          // attempts after a failed one
  std::int64_t messages_failed = 0;  // messages given up (kIoError returned)
};

class LcmPublisher {
 public:
  // The transport seam: returns 0 when the message was handed to the OS
  // (lcm::LCM::publish semantics). Tests inject failures through it.
  using SendFn = std::function<int(const std::string& channel, const void* data, unsigned size)>;

  static Expected<std::unique_ptr<LcmPublisher>> create(const LcmOptions& options,
                                                        std::shared_ptr<lcm::LCM> lcm);
  static Expected<std::unique_ptr<LcmPublisher>> create_with_sender(const LcmOptions& options, SendFn send);

  // site: nullptr while the site anchor is unknown (see to_lcm_pose).
  Status publish_pose(const PoseEstimate& pose, const geo::SitePose* site, const Velocity* velocity = nullptr,
                      const IntegrityOptions& integrity = {});
  Status publish_health(const LcmHealth& health);
  // Sends the pose of the last failed publish_pose again (same attempts
  // rule). Ok and nothing sent when no pose is pending.
  Status retry_pose();
  bool has_pending_pose() const { return !pending_pose_.bytes.empty(); }

  LcmPublisherStats stats() const;
  const LcmOptions& options() const { return options_; }

 private:
  LcmPublisher(const LcmOptions& options, SendFn send, std::shared_ptr<lcm::LCM> lcm)
      : options_(options), send_(std::move(send)), lcm_(std::move(lcm)) {}

  struct Message {
    std::string channel;
    std::vector<std::uint8_t> bytes;
    bool is_pose = false;
  };
  Status send(Message message);

  LcmOptions options_;
  SendFn send_;
  std::shared_ptr<lcm::LCM> lcm_;  // keeps the instance alive; null with a custom sender
  Message pending_pose_;           // last failed pose, empty when none
  std::atomic<std::int64_t> poses_published_{0};
  std::atomic<std::int64_t> health_published_{0};
  std::atomic<std::int64_t> send_failures_{0};
  std::atomic<std::int64_t> retries_{0};
  std::atomic<std::int64_t> messages_failed_{0};
};

}  // namespace sitepose::output
