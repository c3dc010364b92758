#pragma once
// The common start of every `sitepose ablate` command: the config, the
// output folder and the labelled source (a sequence, or a scenario written
// to <out-dir>/sequence).

#include <memory>
#include <string>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::cli {

struct AblationInputs {
  config::SiteposeConfig config;
  std::unique_ptr<experiments::LabelledSource> source;
};

// config_path: empty = defaults. default_scenario: used when the request
// names neither a sequence nor a scenario. Errors name the option.
Expected<AblationInputs> open_ablation_inputs(const std::string& config_path, const std::string& out_dir,
                                              experiments::SourceRequest request,
                                              const std::string& default_scenario);

}  // namespace sitepose::cli
