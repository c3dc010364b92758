#pragma once
// The sitepose settings most commands start from: --config loaded (or the
// built-in defaults) and --mode applied.

#include <string>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"

namespace CLI {
class App;
}

namespace sitepose::cli {

// `config_path` empty: the defaults. `mode` not empty: dynamic.mode. Errors
// name the file, or --mode (exit status 2 for all of them).
Expected<config::SiteposeConfig> load_command_config(const std::string& config_path,
                                                     const std::string& mode = "");

// --scenario (simulated in-process), --sequence (recorded, wins over
// --scenario) and --config, the frame source options of the benches that
// read one sequence; `config_help` says what the command takes from the file.
void add_frame_source_options(CLI::App& sub, std::string& scenario, std::string& sequence,
                              std::string& config_path, const std::string& config_help);

}  // namespace sitepose::cli
