// `sitepose bench sim`: rendering speed of the simulator (stereo frames per
// second, wall and CPU time per frame). A timing, never pass/fail.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <string>

#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/sim/simulator.hpp"

namespace sitepose::cli {
namespace {

struct BenchSimArgs {
  std::string scenario = "crowded";
  int frames = 30;
  int width = 960;
  int height = 540;
};

int run_bench_sim(const BenchSimArgs& a) {
  install_interrupt_handlers();
  if (a.frames < 1) return fail("bench sim", "--frames = " + std::to_string(a.frames) + ": must be >= 1", 2);
  auto scenario = sim::load_scenario(a.scenario);
  if (!scenario) return fail("bench sim", scenario.error().message, scenario.error().exit_status());
  sim::SimOptions options;
  options.width = a.width;
  options.height = a.height;
  const auto t0 = std::chrono::steady_clock::now();
  auto simulator = sim::Simulator::create(*scenario, options);
  if (!simulator) return fail("bench sim", simulator.error().message, simulator.error().exit_status());
  const auto t1 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  double occlusion = 0.0;
  const int n = simulator->frame_count();
  int rendered = 0;
  for (int i = 0; i < a.frames && !interrupted(); ++i, ++rendered) {
    // Spread over the sequence so the view (and occlusion) varies.
    const sim::SimFrame f = simulator->render(static_cast<int>(static_cast<long>(i) * n / a.frames));
    occlusion += f.occlusion_ratio;
  }
  const std::clock_t c1 = std::clock();
  const auto t2 = std::chrono::steady_clock::now();
  const double build_s = std::chrono::duration<double>(t1 - t0).count();
  const double wall_s = std::chrono::duration<double>(t2 - t1).count();
  const double cpu_s = static_cast<double>(c1 - c0) / CLOCKS_PER_SEC;
  const int frames = std::max(rendered, 1);
  std::printf("bench sim: scenario %s, %dx%d, %d stereo frames%s, %d threads\n", a.scenario.c_str(), a.width,
              a.height, rendered, rendered < a.frames ? " (interrupted: partial)" : "", cv::getNumThreads());
  std::printf("  world build     %8.2f s\n", build_s);
  std::printf("  render (wall)   %8.1f ms/frame  %6.1f frames/s\n", wall_s / frames * 1e3, rendered / wall_s);
  std::printf("  render (cpu)    %8.1f ms/frame  (all threads)\n", cpu_s / frames * 1e3);
  std::printf("  mean occlusion  %8.3f\n", occlusion / frames);
  return rendered < a.frames ? report_interrupted("bench sim", "printed the figures of the frames rendered")
                             : 0;
}

void add_options(CLI::App& sub, BenchSimArgs& args) {
  sub.add_option("--scenario", args.scenario, "Scenario name or YAML path")->capture_default_str();
  add_bounded(sub, "--frames", args.frames, "Stereo frames to render", 1, std::numeric_limits<int>::max());
  add_bounded(sub, "--width", args.width, "Image width", 1, std::numeric_limits<int>::max());
  add_bounded(sub, "--height", args.height, "Image height", 1, std::numeric_limits<int>::max());
}

const CommandRegistrar kBenchSim{make_command<BenchSimArgs>(
    "bench", "sim", add_options, run_bench_sim,
    "Simulator rendering speed: stereo frames/s and ms/frame (rendering only, no PNG writing)")};

}  // namespace
}  // namespace sitepose::cli
