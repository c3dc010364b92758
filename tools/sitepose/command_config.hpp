#pragma once
// The sitepose settings most commands start from: --config loaded (or the
// built-in defaults) and --mode applied.

#include <string>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::cli {

// `config_path` empty: the defaults. `mode` not empty: dynamic.mode. Errors
// name the file, or --mode (exit status 2 for all of them).
Expected<config::SiteposeConfig> load_command_config(const std::string& config_path,
                                                     const std::string& mode = "");

}  // namespace sitepose::cli
