#pragma once
// The one logger: spdlog to stderr (journald picks stderr up under systemd).

#include <spdlog/spdlog.h>

#include <string>
#include <string_view>

#include "sitepose/core/expected.hpp"

namespace sitepose {

// Sets the global level from a name (trace, debug, info, warn, error, off).
Status set_log_level(std::string_view level_name);

// Makes the default logger write to stderr under `name`, in colour only on
// a terminal and never when NO_COLOR is set to a non-empty value
// (no-color.org; spdlog 1.10 does not look at it).
void use_stderr_logger(const std::string& name);

// NO_COLOR set and not empty.
bool no_color_requested();

}  // namespace sitepose
