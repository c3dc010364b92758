// `sitepose sim`: render a scenario into a sitepose sequence folder
// (FORMATS.md). Exit status 0 ok, 1 failure while writing, 2 bad usage or a
// bad scenario (the message names the file, key and expectation).

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <string>

#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/sim/scenario.hpp"
#include "sitepose/sim/sequence_writer.hpp"
#include "sitepose/sim/simulator.hpp"

namespace sitepose::cli {
namespace {

struct SimArgs {
  std::string scenario;
  std::string out;
  int frames = 0;
  int seed = -1;
  int width = 0;
  int height = 0;
  double fps = 0.0;
  bool force = false;
  bool list = false;
};

int list_scenarios() {
  auto entries = sim::list_scenarios();
  if (!entries) return fail("sim", entries.error().message, 2);
  int name_width = 0;
  for (const auto& e : *entries) name_width = std::max(name_width, static_cast<int>(e.name.size()));
  for (const auto& e : *entries) std::printf("%-*s  %s\n", name_width, e.name.c_str(), e.description.c_str());
  return 0;
}

int run_sim(const SimArgs& a, CLI::App& sub) {
  if (a.list) return list_scenarios();
  install_interrupt_handlers();
  if (a.scenario.empty() || a.out.empty()) {
    return fail("sim", "--scenario and --out are required (or --list)", 2);
  }
  if (auto st = sim::check_sequence_output(a.out, a.force); !st) return fail("sim", st.error().message, 2);
  auto scenario = sim::load_scenario(a.scenario);
  if (!scenario) return fail("sim", scenario.error().message, scenario.error().exit_status());
  sim::SimOptions options;
  if (sub.count("--frames")) options.frames = a.frames;
  if (sub.count("--seed")) options.seed = a.seed;
  if (sub.count("--width")) options.width = a.width;
  if (sub.count("--height")) options.height = a.height;
  if (sub.count("--fps")) options.fps = a.fps;
  auto simulator = sim::Simulator::create(*scenario, options);
  if (!simulator) return fail("sim", simulator.error().message, simulator.error().exit_status());

  sim::WriteOptions write;
  write.force = a.force;
  write.stop = [] { return interrupted(); };
  const bool tty = isatty(STDERR_FILENO) != 0;
  write.progress = [tty](int done, int total) {
    if (tty) {
      const int width = 40;
      const int filled = done * width / total;
      std::fprintf(stderr, "\r[%s%s] %d/%d", std::string(static_cast<size_t>(filled), '#').c_str(),
                   std::string(static_cast<size_t>(width - filled), '.').c_str(), done, total);
      if (done == total) std::fprintf(stderr, "\n");
    } else if (done == total || done % std::max(1, total / 4) == 0) {
      std::fprintf(stderr, "sitepose sim: %d/%d frames\n", done, total);
    }
  };
  std::fprintf(stderr, "sitepose sim: scenario %s, seed %d, %d frames at %g fps, %dx%d -> %s\n",
               simulator->scenario().name.c_str(), simulator->scenario().seed, simulator->frame_count(),
               simulator->fps(), simulator->camera().width, simulator->camera().height, a.out.c_str());
  auto summary = sim::write_sequence(*simulator, a.out, write);
  if (!summary) return fail("sim", summary.error().message, summary.error().exit_status());
  if (summary->partial) {
    if (tty) std::fprintf(stderr, "\n");
    const std::string what = "wrote the first " + std::to_string(summary->frames) + " of " +
                             std::to_string(simulator->frame_count()) + " frames to " + a.out +
                             " as a complete sequence (meta.json \"partial\": true)";
    return report_interrupted("sim", what.c_str());
  }
  std::printf("wrote %d frames to %s in %.1f s (%.1f frames/s); occlusion ratio max %.3f, mean %.3f\n",
              summary->frames, a.out.c_str(), summary->seconds, summary->frames / summary->seconds,
              summary->max_occlusion_ratio, summary->mean_occlusion_ratio);
  return 0;
}

const CommandRegistrar kSim{
    {"", "sim", "Render a construction-site scenario into a stereo sequence with ground truth",
     [](CLI::App& sub) -> CommandAction {
       auto args = std::make_shared<SimArgs>();
       sub.add_option("--scenario", args->scenario,
                      "Scenario name (see --list) or path to a scenario YAML file");
       sub.add_option("--out", args->out,
                      "Output folder (sitepose sequence layout); must be empty unless --force");
       sub.add_option("--frames", args->frames, "Number of frames (default: the scenario's duration_s x fps)")
           ->check(CLI::Range(1, std::numeric_limits<int>::max()));
       sub.add_option("--seed", args->seed,
                      "Seed of textures, layout, exposure and noise (default: the scenario's)");
       sub.add_option("--width", args->width, "Image width in pixels (focal length scales, the view is kept)")
           ->check(CLI::Range(1, std::numeric_limits<int>::max()));
       sub.add_option("--height", args->height,
                      "Image height in pixels (focal length scales, the view is kept)")
           ->check(CLI::Range(1, std::numeric_limits<int>::max()));
       sub.add_option("--fps", args->fps, "Frame rate (default: the scenario's)")
           ->check(CLI::Range(0.001, 1000.0));
       sub.add_flag("--force", args->force, "Replace a sequence already in --out");
       sub.add_flag("--list", args->list, "List the shipped scenarios, one per line, and exit");
       return [args, &sub] { return run_sim(*args, sub); };
     }}};

}  // namespace
}  // namespace sitepose::cli
