#include "sitepose/core/log.hpp"

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

}  // namespace sitepose
