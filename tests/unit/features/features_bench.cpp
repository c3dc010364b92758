// Timing of the features module at 960x540 (not a test; run by hand):
//   build/<dir>/tests/unit/features/features_bench
// Images are generated (shapes scene, three disparity bands).

#include <benchmark/benchmark.h>

#include <future>

#include "sitepose/features/stereo_extractor.hpp"
#include "sitepose/testing/cameras.hpp"
#include "sitepose/testing/images.hpp"

namespace sitepose::features {
namespace {

struct Scene {
  cv::Mat left;
  cv::Mat right;
  StereoCamera camera;
  Scene() {
    left = testing::make_shapes_scene(cv::Size(960, 540), 31);
    right = testing::render_right(left, {180, 360, 540}, {10.3, 33.7, 50.0});
    camera = testing::centred_camera(960, 540, 700.0, 0.5);
  }
};

const Scene& scene() {
  static const Scene s;
  return s;
}

void BM_ExtractLeft(benchmark::State& state) {
  OrbExtractor extractor(config::OrbConfig{});
  for (auto _ : state) benchmark::DoNotOptimize(extractor.extract(scene().left));
}
BENCHMARK(BM_ExtractLeft)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ExtractRight(benchmark::State& state) {
  OrbExtractor extractor(config::OrbConfig{});
  for (auto _ : state) benchmark::DoNotOptimize(extractor.extract(scene().right));
}
BENCHMARK(BM_ExtractRight)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ExtractBothConcurrently(benchmark::State& state) {
  OrbExtractor left(config::OrbConfig{});
  OrbExtractor right(config::OrbConfig{});
  for (auto _ : state) {
    auto r = std::async(std::launch::async, [&] { return right.extract(scene().right); });
    auto l = left.extract(scene().left);
    benchmark::DoNotOptimize(l);
    benchmark::DoNotOptimize(r.get());
  }
}
BENCHMARK(BM_ExtractBothConcurrently)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StereoMatch(benchmark::State& state) {
  OrbExtractor extractor(config::OrbConfig{});
  const OrbFeatures l = extractor.extract(scene().left).value();
  const OrbFeatures r = extractor.extract(scene().right).value();
  StereoMatcher matcher(config::StereoMatchConfig{}, scene().camera.bf());
  int matched = 0;
  for (auto _ : state) {
    auto m = matcher.match(l, r);
    matched = m->stats.n_matched;
    benchmark::DoNotOptimize(m);
  }
  state.counters["matched"] = matched;
  state.counters["left"] = static_cast<double>(l.keypoints.size());
}
BENCHMARK(BM_StereoMatch)->Unit(benchmark::kMillisecond)->UseRealTime();

// Reference point on the same machine: OpenCV's own ORB, 1500 features.
void BM_OpenCvOrbReference(benchmark::State& state) {
  auto orb = cv::ORB::create(1500);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) orb->detectAndCompute(scene().left, cv::noArray(), keypoints, descriptors);
}
BENCHMARK(BM_OpenCvOrbReference)->Unit(benchmark::kMillisecond)->UseRealTime();

// Both images and their levels on a pool of one worker plus the caller, as
// SlamSystem runs it.
void BM_StereoExtractorTotal(benchmark::State& state) {
  TaskPool pool(1);
  StereoExtractorOptions options;
  options.pool = &pool;
  StereoExtractor extractor(config::OrbConfig{}, config::StereoMatchConfig{}, scene().camera, options);
  for (auto _ : state) benchmark::DoNotOptimize(extractor.extract(scene().left, scene().right));
}
BENCHMARK(BM_StereoExtractorTotal)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace sitepose::features

BENCHMARK_MAIN();
