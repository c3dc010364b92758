#include "ablation_inputs.hpp"

#include <filesystem>

#include "sitepose/config/config.hpp"

namespace sitepose::cli {

Expected<AblationInputs> open_ablation_inputs(const std::string& config_path, const std::string& out_dir,
                                              experiments::SourceRequest request,
                                              const std::string& default_scenario) {
  AblationInputs inputs;
  if (!config_path.empty()) {
    SITEPOSE_TRY(inputs.config, config::load_config(config_path));
  }
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return make_error(ErrorCode::kInvalidArgument, "--out-dir " + out_dir + ": " + ec.message());
  if (request.sequence.empty() && request.scenario.empty()) request.scenario = default_scenario;
  if (request.temp_dir.empty()) request.temp_dir = out_dir + "/sequence";
  SITEPOSE_TRY(inputs.source, experiments::open_ablation_source(request));
  return inputs;
}

}  // namespace sitepose::cli
