#pragma once
// The sitepose settings most commands start from: --config loaded (or the
// built-in defaults) and --mode applied.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace CLI {
class App;
}

namespace sitepose::cli {

// `config_path` empty: the defaults. `mode` not empty: dynamic.mode. Errors
// name the file, or --mode (exit status 2 for all of them).
Expected<config::SiteposeConfig> load_command_config(const std::string& config_path,
                                                     const std::string& mode = "");

// The settings of the benches that run the daemon's pipeline. (The {}
// initializers let a command set one field by name, {.mode = "full"},
// without GCC's -Wmissing-field-initializers.)
struct PipelineConfigArgs {
  std::string config_path{};  // empty: the defaults
  std::string mode{};         // empty: the config's dynamic.mode
  std::string detector{};     // empty: the config's detector.name
};

// load_command_config with the detector set and the classes it reports as
// dynamic by construction added, as siteposed prepares its config.
Expected<config::SiteposeConfig> load_pipeline_config(const PipelineConfigArgs& args);

// The frames and config of the benches that read one sequence: a recorded
// sequence, or else a scenario simulated in-process. ({} as above.)
struct FrameSourceArgs {
  std::string scenario{};
  std::string sequence{};  // wins over `scenario`
  std::string config_path{};
  std::optional<double> fps{};  // the scenario's frame rate instead of its own; unset = its own
};

// --fps: the rate to render a scenario at (unset, the default, = its own).
void add_fps_option(CLI::App& sub, std::optional<double>& fps);

// --scenario, --sequence, --fps and --config, bound to `source`, which must
// outlive the parse; `config_help` says what the command takes from the file.
void add_frame_source_options(CLI::App& sub, FrameSourceArgs& source, const std::string& config_help);

// The sequence (labels not required), or else the first `frames` frames of
// the scenario (0 = all).
Expected<std::unique_ptr<experiments::LabelledSource>> open_frame_source(const FrameSourceArgs& source,
                                                                         int frames);

// --vocabulary FILE of the benches that train a vocabulary without one;
// `without_it` ends the help: what they train on.
void add_bench_vocabulary_option(CLI::App& sub, std::string& path, const std::string& without_it);

// The vocabulary in `path`, or, when it is empty, one trained on
// training_images() with the default parameters.
Expected<std::shared_ptr<const placerec::Vocabulary>> load_or_train_vocabulary(
    const std::string& path, const std::function<Expected<std::vector<cv::Mat>>()>& training_images);

}  // namespace sitepose::cli
