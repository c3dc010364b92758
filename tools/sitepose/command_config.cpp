#include "command_config.hpp"

#include <CLI/CLI.hpp>

#include "sitepose/config/config.hpp"
#include "sitepose/detect/create_detector.hpp"

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

Expected<config::SiteposeConfig> load_pipeline_config(const PipelineConfigArgs& args) {
  SITEPOSE_TRY(config::SiteposeConfig config, load_command_config(args.config_path, args.mode));
  if (!args.detector.empty()) config.detector.name = args.detector;
  detect::add_inherent_dynamic_classes(config.detector, config.dynamic);
  return config;
}

void add_fps_option(CLI::App& sub, std::optional<double>& fps) {
  sub.add_option("--fps", fps,
                 "Render the scenario at this frame rate, same motion in time (default: the scenario's; not "
                 "with --sequence)")
      ->check(CLI::Range(0.001, 1000.0));
}

void add_frame_source_options(CLI::App& sub, FrameSourceArgs& source, const std::string& config_help) {
  sub.add_option("--scenario", source.scenario, "Scenario to simulate in-process (ignored with --sequence)")
      ->capture_default_str();
  sub.add_option("--sequence", source.sequence, "Recorded sequence directory instead of a scenario");
  add_fps_option(sub, source.fps);
  sub.add_option("--config", source.config_path, config_help);
}

Expected<std::unique_ptr<experiments::LabelledSource>> open_frame_source(const FrameSourceArgs& source,
                                                                         int frames) {
  SITEPOSE_TRY_STATUS(experiments::check_fps_for_source(!source.sequence.empty(), source.fps));
  if (!source.sequence.empty()) return experiments::open_labelled_sequence(source.sequence, false);
  return experiments::open_simulated(source.scenario, frames, std::nullopt, std::nullopt, std::nullopt,
                                     source.fps);
}

void add_bench_vocabulary_option(CLI::App& sub, std::string& path, const std::string& without_it) {
  sub.add_option("--vocabulary", path, "Vocabulary file (sitepose vocab train); default: " + without_it)
      ->check(CLI::ExistingFile);
}

Expected<std::shared_ptr<const placerec::Vocabulary>> load_or_train_vocabulary(
    const std::string& path, const std::function<Expected<std::vector<cv::Mat>>()>& training_images) {
  if (!path.empty()) {
    SITEPOSE_TRY(placerec::Vocabulary loaded, placerec::Vocabulary::load(path));
    return std::make_shared<const placerec::Vocabulary>(std::move(loaded));
  }
  SITEPOSE_TRY(std::vector<cv::Mat> images, training_images());
  SITEPOSE_TRY(placerec::Vocabulary trained, placerec::Vocabulary::train(images));
  return std::make_shared<const placerec::Vocabulary>(std::move(trained));
}

}  // namespace sitepose::cli
