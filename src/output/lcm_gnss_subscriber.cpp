#include "sitepose/output/lcm_gnss_subscriber.hpp"

#include <fmt/format.h>

#include "sitepose/output/lcm_messages.hpp"

namespace sitepose::output {

Expected<std::unique_ptr<LcmGnssSubscriber>> LcmGnssSubscriber::create(
    const LcmOptions& options, std::shared_ptr<lcm::LCM> lcm, FixCallback on_fix) {
  SITEPOSE_TRY_STATUS(options.validate());
  if (!lcm || !lcm->good()) {
    return make_error(ErrorCode::kInvalidArgument, "LcmGnssSubscriber: no usable lcm::LCM instance");
  }
  if (!on_fix) return make_error(ErrorCode::kInvalidArgument, "LcmGnssSubscriber: empty callback");
  std::unique_ptr<LcmGnssSubscriber> subscriber(
      new LcmGnssSubscriber(std::move(lcm), std::move(on_fix)));
  // LCM treats the channel as a regular expression; match it literally.
  std::string pattern;
  for (char c : options.gnss_channel) {
    if (std::string_view(".[]{}()\\*+?^$|").find(c) != std::string_view::npos) pattern += '\\';
    pattern += c;
  }
  subscriber->subscription_ = subscriber->lcm_->subscribe(
      pattern, &LcmGnssSubscriber::on_message, subscriber.get());
  if (subscriber->subscription_ == nullptr) {
    return make_error(ErrorCode::kIoError,
                      fmt::format("LCM: cannot subscribe to {}", options.gnss_channel));
  }
  return subscriber;
}

LcmGnssSubscriber::~LcmGnssSubscriber() {
  if (subscription_ != nullptr) lcm_->unsubscribe(subscription_);
}

Expected<bool> LcmGnssSubscriber::handle(int timeout_ms) {
  const int rc = lcm_->handleTimeout(timeout_ms);
  if (rc < 0) return make_error(ErrorCode::kIoError, "LCM handleTimeout failed");
  return rc > 0;
}

void LcmGnssSubscriber::on_message(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  auto message = decode_lcm<sitepose::gnss_fix_t>(buffer->data, buffer->data_size);
  Expected<geo::GnssFix> fix = message ? from_lcm_gnss_fix(*message)
                                       : Expected<geo::GnssFix>(Unexpected{message.error()});
  if (!fix) {
    if (messages_rejected_.fetch_add(1, std::memory_order_relaxed) == 0) {
      first_rejection_ = fmt::format("{}: {}", channel, fix.error().message);
    }
    return;
  }
  fixes_received_.fetch_add(1, std::memory_order_relaxed);
  on_fix_(*fix);
}

}  // namespace sitepose::output
