#include "sitepose/output/lcm_bus.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <string_view>

#include "sitepose/core/echo.hpp"

namespace sitepose::output {
namespace {

bool parse_uint(std::string_view text, unsigned min, unsigned max) {
  unsigned value = 0;
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size() && !text.empty() &&
         value >= min && value <= max;
}

// "a.b.c.d" with every part 0..255; the first part in 224..239 (multicast).
bool is_multicast_ipv4(std::string_view text) {
  for (int part = 0; part < 4; ++part) {
    const std::size_t dot = part < 3 ? text.find('.') : text.size();
    if (dot == std::string_view::npos) return false;
    if (!parse_uint(text.substr(0, dot), part == 0 ? 224 : 0, part == 0 ? 239 : 255)) return false;
    text.remove_prefix(std::min(text.size(), dot + 1));
  }
  return true;
}

// What is wrong with a URL LCM 1.3 would refuse; empty when it parses.
std::string lcm_url_problem(std::string_view url) {
  const std::size_t scheme_end = url.find("://");
  if (scheme_end == std::string_view::npos) return "expected provider://network?options";
  const std::string_view provider = url.substr(0, scheme_end);
  std::string_view rest = url.substr(scheme_end + 3);
  const std::size_t query = rest.find('?');
  const std::string_view network = rest.substr(0, query);
  if (query != std::string_view::npos) {
    std::string_view options = rest.substr(query + 1);
    while (!options.empty()) {
      const std::size_t amp = options.find('&');
      const std::string_view option = options.substr(0, amp);
      const std::size_t eq = option.find('=');
      if (eq == std::string_view::npos || eq == 0) return "options must be key=value, joined by &";
      if (option.substr(0, eq) == "ttl" && !parse_uint(option.substr(eq + 1), 0, 255)) {
        return "ttl must be 0..255";
      }
      options = amp == std::string_view::npos ? std::string_view() : options.substr(amp + 1);
    }
  }
  if (provider == "memq") return "";
  if (provider == "file" || provider == "tcpq")
    return network.empty() ? "the provider needs a path or host" : "";
  if (provider != "udpm") return "unknown provider (udpm, memq, file or tcpq)";
  if (network.empty()) return "";
  const std::size_t colon = network.find(':');
  if (!is_multicast_ipv4(network.substr(0, colon)))
    return "udpm needs a multicast IPv4 address (224..239.x.x.x)";
  if (colon != std::string_view::npos && !parse_uint(network.substr(colon + 1), 1, 65535)) {
    return "port must be 1..65535";
  }
  return "";
}

}  // namespace

Status check_lcm_url(const std::string& url, const std::string& key) {
  if (url.empty()) return ok_status();
  const std::string problem = lcm_url_problem(url);
  if (problem.empty()) return ok_status();
  return make_error(ErrorCode::kInvalidArgument,
                    fmt::format("{} = \"{}\": {}", key, echo_value(url), problem));
}

Status LcmOptions::validate(const std::string& prefix) const {
  const auto channel_ok = [&](const char* key, const std::string& value) -> Status {
    if (value.empty() || value.size() > 63) {
      return make_error(
          ErrorCode::kInvalidArgument,
          fmt::format("{}.{} = '{}': expected a channel name of 1..63 characters", prefix, key, value));
    }
    return ok_status();
  };
  SITEPOSE_TRY_STATUS(channel_ok("pose_channel", pose_channel));
  SITEPOSE_TRY_STATUS(channel_ok("health_channel", health_channel));
  SITEPOSE_TRY_STATUS(channel_ok("gnss_channel", gnss_channel));
  if (pose_channel == health_channel || pose_channel == gnss_channel || health_channel == gnss_channel) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}: pose_channel '{}', health_channel '{}' and gnss_channel '{}' "
                                  "must differ",
                                  prefix, pose_channel, health_channel, gnss_channel));
  }
  SITEPOSE_TRY_STATUS(check_lcm_url(url, prefix + ".url"));
  if (max_send_attempts < 1 || max_send_attempts > 10) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("{}.max_send_attempts = {}: must be in 1..10", prefix, max_send_attempts));
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
