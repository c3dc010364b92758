#include "sitepose/core/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <cstdlib>
#include <string>

namespace sitepose {

Status set_log_level(std::string_view level_name) {
  const auto level = spdlog::level::from_str(std::string(level_name));
  // from_str maps unknown names to "off"; only accept "off" when asked for.
  if (level == spdlog::level::off && level_name != "off") {
    return make_error(ErrorCode::kInvalidArgument,
                      "unknown log level '" + std::string(level_name) +
                          "': expected trace, debug, info, warn, error or off");
  }
  spdlog::set_level(level);
  return ok_status();
}

bool no_color_requested() {
  const char* value = std::getenv("NO_COLOR");
  return value != nullptr && value[0] != '\0';
}

void use_stderr_logger(const std::string& name) {
  const auto mode = no_color_requested() ? spdlog::color_mode::never : spdlog::color_mode::automatic;
  auto logger = spdlog::get(name);
  if (!logger) logger = spdlog::stderr_color_mt(name, mode);
  spdlog::set_default_logger(std::move(logger));
}

}  // namespace sitepose
