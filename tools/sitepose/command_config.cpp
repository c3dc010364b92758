#include "command_config.hpp"

#include "sitepose/config/config.hpp"

namespace sitepose::cli {

Expected<config::SiteposeConfig> load_command_config(const std::string& config_path, const std::string& mode) {
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

}  // namespace sitepose::cli
