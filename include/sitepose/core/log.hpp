#pragma once
// The one logger: spdlog to stderr (journald picks stderr up under systemd).

#include <spdlog/spdlog.h>

#include <string_view>

#include "sitepose/core/expected.hpp"

namespace sitepose {

// Sets the global level from a name (trace, debug, info, warn, error, off).
Status set_log_level(std::string_view level_name);

}  // namespace sitepose
