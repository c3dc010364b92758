// Timing of motion-only BA on a synthetic stereo frame and of local BA on a
// synthetic map (not a test; run by hand: build target
// optim_motion_ba_benchmark). The tracker needs one full 4-round solve of
// ~500 observations in a few ms (>= 30 frames/s overall).

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "sitepose/optim/local_ba.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/testing/pose_scene.hpp"

namespace sitepose::optim {
namespace {

using namespace testing;  // NOLINT: test helpers

std::vector<PoseObservation> frame_observations(int n, double outlier_fraction, SE3* T_world_cam) {
  std::mt19937 rng(99);
  const StereoCamera camera = hd_camera();
  *T_world_cam = test_pose_world_cam();
  const SE3 T_cam_world = T_world_cam->inverse();
  std::uniform_int_distribution<int> level(0, 7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<PoseObservation> obs;
  for (int i = 0; i < n; ++i) {
    PoseObservation o = exact_observation(camera, T_cam_world,
                                          *T_world_cam * random_point_cam(camera, 3.0, 40.0, rng),
                                          level(rng), false);
    if (unit(rng) < outlier_fraction) {
      make_gross_outlier(camera, o, rng);
    } else {
      add_noise(o, rng);
    }
    obs.push_back(o);
  }
  return obs;
}

void BM_MotionOnlyBa(benchmark::State& state) {
  SE3 T_world_cam;
  const auto obs = frame_observations(static_cast<int>(state.range(0)), 0.2, &T_world_cam);
  std::mt19937 rng(5);
  // A constant-velocity prediction is typically a few cm / tenths of a degree off.
  const SE3 init = perturb(T_world_cam, 0.05, 0.5 * kDegToRad, rng).inverse();
  const MotionOnlyBa ba(hd_camera(), config::TrackingConfig{});
  int iterations = 0;
  for (auto _ : state) {
    auto result = ba.solve(init, obs);
    iterations = result->iterations;
    benchmark::DoNotOptimize(result);
  }
  state.counters["lm_iterations"] = iterations;
}
BENCHMARK(BM_MotionOnlyBa)->Arg(100)->Arg(300)->Arg(500)->Arg(1000)->Unit(benchmark::kMicrosecond);

// Local BA of 8 keyframes (2 fixed), 300 points, ~2000 observations, 5 %
// gross outliers; both stages with the default 5 + 10 iterations.
void BM_LocalBa(benchmark::State& state) {
  const MapScene scene = make_map_scene(0.05, 3);
  const LocalBa ba(hd_camera(), config::MappingConfig{}, config::TrackingConfig{});
  int iterations = 0;
  for (auto _ : state) {
    auto result = ba.solve(scene.input, nullptr);
    iterations = result->iterations;
    benchmark::DoNotOptimize(result);
  }
  state.counters["observations"] = static_cast<double>(scene.input.observations.size());
  state.counters["lm_iterations"] = iterations;
}
BENCHMARK(BM_LocalBa)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace sitepose::optim

BENCHMARK_MAIN();
