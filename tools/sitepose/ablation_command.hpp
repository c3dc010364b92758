#pragma once
// The skeleton of every `sitepose ablate` command: its options (the
// labelled source, the config, the output folder) and what they open before
// the ablation runs: the config, the output folder and the labelled source
// (a sequence, or a scenario written to <out-dir>/sequence).

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "command_registry.hpp"
#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::cli {

struct AblationArgs {
  experiments::SourceRequest source;
  std::string config_path;
  std::string out_dir;
  std::string default_scenario;  // used when neither --sequence nor --scenario is given
};

// What the help says of the options that differ between the commands.
struct AblationHelp {
  std::string default_scenario;
  std::string sequence;  // --sequence: what the sequence must hold
  std::string config;    // --config: what the command sets in it
  std::string outputs;   // --out-dir: the files written
};

// Adds --sequence, --scenario, --frames, --config and --out-dir (required),
// bound to `args`, which must outlive the parse.
void add_ablation_options(CLI::App& sub, AblationArgs& args, const AblationHelp& help);

struct AblationInputs {
  config::SiteposeConfig config;
  std::unique_ptr<experiments::LabelledSource> source;
};

// Errors name the option.
Expected<AblationInputs> open_ablation_inputs(const AblationArgs& args);

// What an ablation does with its opened inputs; returns the exit status.
using AblationRun = std::function<int(const AblationArgs& args, config::SiteposeConfig& config,
                                      const experiments::LabelledSource& source)>;

// The source's last path component (a sequence folder's name), for chart titles.
std::string source_title(const experiments::LabelledSource& source);

// Writes <out_dir>/<name>.csv and <out_dir>/<name>.png and prints their
// paths; exit status 0, or 1 with the message naming `command` when a write
// fails.
int write_csv_and_png(const std::string& command, const std::string& out_dir, const std::string& name,
                      const std::string& csv, const cv::Mat& png);

// `sitepose ablate <name>` with the options above; the inputs are opened
// (failure: exit status 2, the message naming the option) before `run`.
CommandSpec ablation_command(const std::string& name, const std::string& description,
                             const AblationHelp& help, AblationRun run);

}  // namespace sitepose::cli
