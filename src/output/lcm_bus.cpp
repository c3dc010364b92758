#include "sitepose/output/lcm_bus.hpp"

#include <fmt/format.h>

namespace sitepose::output {

Status LcmOptions::validate(const std::string& prefix) const {
  const auto channel_ok = [&](const char* key, const std::string& value) -> Status {
    if (value.empty() || value.size() > 63) {
      return make_error(ErrorCode::kInvalidArgument,
                        fmt::format("{}.{} = '{}': expected a channel name of 1..63 characters",
                                    prefix, key, value));
    }
    return ok_status();
  };
  SITEPOSE_TRY_STATUS(channel_ok("pose_channel", pose_channel));
  SITEPOSE_TRY_STATUS(channel_ok("health_channel", health_channel));
  SITEPOSE_TRY_STATUS(channel_ok("gnss_channel", gnss_channel));
  if (pose_channel == health_channel || pose_channel == gnss_channel ||
      health_channel == gnss_channel) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}: pose_channel '{}', health_channel '{}' and gnss_channel '{}' "
                                  "must differ",
                                  prefix, pose_channel, health_channel, gnss_channel));
  }
  if (max_send_attempts < 1 || max_send_attempts > 10) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}.max_send_attempts = {}: must be in 1..10", prefix,
                                  max_send_attempts));
  }
  return ok_status();
}

Expected<std::shared_ptr<lcm::LCM>> open_lcm(const std::string& url) {
  auto lcm = std::make_shared<lcm::LCM>(url);
  if (!lcm->good()) {
    return make_error(ErrorCode::kIoError,
                      fmt::format("LCM: cannot open provider '{}' (udpm needs a multicast route, "
                                  "e.g. ip route add 224.0.0.0/4 dev lo)",
                                  url.empty() ? "default" : url));
  }
  return lcm;
}

}  // namespace sitepose::output
