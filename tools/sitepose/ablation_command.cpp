#include "ablation_command.hpp"

#include <cstdio>
#include <filesystem>
#include <limits>
#include <utility>

#include "command_config.hpp"
#include "sitepose/experiments/charts.hpp"

namespace sitepose::cli {

void add_ablation_options(CLI::App& sub, AblationArgs& args, const AblationHelp& help) {
  args.default_scenario = help.default_scenario;
  sub.add_option("--sequence", args.source.sequence, help.sequence);
  sub.add_option(
      "--scenario", args.source.scenario,
      "Scenario to simulate into <out-dir>/sequence instead (default: " + help.default_scenario + ")");
  sub.add_option("--frames", args.source.frames, "Frames to simulate (0 = the whole scenario)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()));
  sub.add_option("--config", args.config_path, help.config);
  sub.add_option("--out-dir", args.out_dir, "Output folder: " + help.outputs)->required();
}

Expected<AblationInputs> open_ablation_inputs(const AblationArgs& args) {
  AblationInputs inputs;
  SITEPOSE_TRY(inputs.config, load_command_config(args.config_path));
  std::error_code ec;
  std::filesystem::create_directories(args.out_dir, ec);
  if (ec) return make_error(ErrorCode::kInvalidArgument, "--out-dir " + args.out_dir + ": " + ec.message());
  experiments::SourceRequest request = args.source;
  if (request.sequence.empty() && request.scenario.empty()) request.scenario = args.default_scenario;
  if (request.temp_dir.empty()) request.temp_dir = args.out_dir + "/sequence";
  SITEPOSE_TRY(inputs.source, experiments::open_ablation_source(request));
  return inputs;
}

std::string source_title(const experiments::LabelledSource& source) {
  return std::filesystem::path(source.name()).filename().string();
}

int write_csv_and_png(const std::string& command, const std::string& out_dir, const std::string& name,
                      const std::string& csv, const cv::Mat& png) {
  const std::string csv_path = out_dir + "/" + name + ".csv";
  const std::string png_path = out_dir + "/" + name + ".png";
  if (auto st = experiments::write_text(csv_path, csv); !st) return fail(command, st.error().message, 1);
  if (auto st = experiments::write_png(png_path, png); !st) return fail(command, st.error().message, 1);
  std::printf("wrote %s, %s\n", csv_path.c_str(), png_path.c_str());
  return 0;
}

CommandSpec ablation_command(const std::string& name, const std::string& description,
                             const AblationHelp& help, AblationRun run) {
  return make_command<AblationArgs>(
      "ablate", name, [help](CLI::App& sub, AblationArgs& args) { add_ablation_options(sub, args, help); },
      [name, run = std::move(run)](const AblationArgs& args) {
        auto inputs = open_ablation_inputs(args);
        if (!inputs) return fail("ablate " + name, inputs.error().message, 2);
        return run(args, inputs->config, *inputs->source);
      },
      description);
}

}  // namespace sitepose::cli
