#include "command_config.hpp"

#include <CLI/CLI.hpp>

#include "sitepose/config/config.hpp"

namespace sitepose::cli {

Expected<config::SiteposeConfig> load_command_config(const std::string& config_path,
                                                     const std::string& mode) {
  config::SiteposeConfig config;
  if (!config_path.empty()) {
    SITEPOSE_TRY(config, config::load_config(config_path));
  }
  if (!mode.empty()) {
    auto parsed = config::parse_masking_mode(mode);
    if (!parsed) return make_error(parsed.error().code, "--mode: " + parsed.error().message);
    config.dynamic.mode = *parsed;
  }
  return config;
}

void add_frame_source_options(CLI::App& sub, std::string& scenario, std::string& sequence,
                              std::string& config_path, const std::string& config_help) {
  sub.add_option("--scenario", scenario, "Scenario to simulate in-process (ignored with --sequence)")
      ->capture_default_str();
  sub.add_option("--sequence", sequence, "Recorded sequence directory instead of a scenario");
  sub.add_option("--config", config_path, config_help);
}

}  // namespace sitepose::cli
