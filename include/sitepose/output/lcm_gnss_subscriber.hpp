#pragma once
// Receiving GNSS fixes (gnss_fix_t) over LCM for the online site anchor.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/geo/gnss_fix.hpp"
#include "sitepose/output/lcm_bus.hpp"

namespace sitepose::output {

// Receives gnss_fix_t on options.gnss_channel and hands each valid fix to
// the callback, on the thread that calls handle(). Messages that do not
// decode or carry an invalid fix are counted and dropped (the first reason
// is kept). The callback must not call handle() itself.
class LcmGnssSubscriber {
 public:
  using FixCallback = std::function<void(const geo::GnssFix&)>;

  static Expected<std::unique_ptr<LcmGnssSubscriber>> create(const LcmOptions& options,
                                                             std::shared_ptr<lcm::LCM> lcm,
                                                             FixCallback on_fix);
  ~LcmGnssSubscriber();
  LcmGnssSubscriber(const LcmGnssSubscriber&) = delete;
  LcmGnssSubscriber& operator=(const LcmGnssSubscriber&) = delete;

  // Waits up to timeout_ms for one LCM message and dispatches it (to every
  // subscription of the shared lcm::LCM). true: a message was handled;
  // false: timeout; kIoError when LCM reports an error.
  Expected<bool> handle(int timeout_ms);
  // For poll()/epoll in the daemon's own loop.
  int fileno() const { return lcm_->getFileno(); }

  std::int64_t fixes_received() const { return fixes_received_.load(std::memory_order_relaxed); }
  std::int64_t messages_rejected() const { return messages_rejected_.load(std::memory_order_relaxed); }
  // "" until a message is rejected; read from the handle() thread.
  const std::string& first_rejection() const { return first_rejection_; }

 private:
  LcmGnssSubscriber(std::shared_ptr<lcm::LCM> lcm, FixCallback on_fix)
      : lcm_(std::move(lcm)), on_fix_(std::move(on_fix)) {}
  void on_message(const lcm::ReceiveBuffer* buffer, const std::string& channel);

  std::shared_ptr<lcm::LCM> lcm_;
  FixCallback on_fix_;
  lcm::Subscription* subscription_ = nullptr;  // owned by lcm_, released in the destructor
  std::atomic<std::int64_t> fixes_received_{0};
  std::atomic<std::int64_t> messages_rejected_{0};
  std::string first_rejection_;
};

}  // namespace sitepose::output
