// `sitepose bench features`: the masked grid ORB extractor (features::
// OrbExtractor) against cv::ORB with the same feature count, levels and
// scale on the same left images, measured side by side in one run: ours on
// the calling thread alone, ours with its levels on a TaskPool, cv::ORB.
// Timings only, never pass/fail. Ctrl-C / SIGTERM: the figures of the frames
// done, marked partial, exit 130.

#include <chrono>
#include <cstdio>
#include <memory>
#include <opencv2/features2d.hpp>
#include <string>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/features/orb_extractor.hpp"
#include "sitepose/slam/run_recorder.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench features";

struct Args {
  FrameSourceArgs input{.scenario = "static"};
  int frames = 30;
  int repeats = 3;
  int pool_workers = 1;
};

double ms_between(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

int run(const Args& args) {
  install_interrupt_handlers();
  auto loaded = load_command_config(args.input.config_path);
  if (!loaded) return fail(kCommand, loaded.error().message, 2);
  const config::OrbConfig& orb = loaded->orb;
  auto source = open_frame_source(args.input, args.frames);
  if (!source) return fail(kCommand, source.error().message, 2);
  auto ours = features::OrbExtractor::create(orb);
  if (!ours) return fail(kCommand, ours.error().message, 2);
  features::TaskPool pool(std::max(0, args.pool_workers));
  auto pooled = features::OrbExtractor::create(orb, &pool);
  if (!pooled) return fail(kCommand, pooled.error().message, 2);
  // OpenCV's defaults otherwise (FAST threshold 20, Harris ranking, edge 31).
  cv::Ptr<cv::ORB> reference =
      cv::ORB::create(orb.n_features, static_cast<float>(orb.scale_factor), orb.n_levels);
  std::vector<double> ours_ms;
  std::vector<double> pooled_ms;
  std::vector<double> cv_ms;
  double ours_kps = 0.0;
  double pooled_kps = 0.0;
  double cv_kps = 0.0;
  const int frames = args.frames > 0 ? std::min(args.frames, (*source)->size()) : (*source)->size();
  cv::Size size;
  int done = 0;
  for (; done < frames && !interrupted(); ++done) {
    auto frame = (*source)->read(done);
    if (!frame) return fail(kCommand, frame.error().message, 2);
    const cv::Mat& image = frame->frame.left;
    size = image.size();
    for (int r = 0; r < args.repeats; ++r) {  // alternate, so all see the same cache and load
      const auto t0 = std::chrono::steady_clock::now();
      auto features = ours->extract(image);
      const auto t1 = std::chrono::steady_clock::now();
      std::vector<cv::KeyPoint> keypoints;
      cv::Mat descriptors;
      reference->detectAndCompute(image, cv::noArray(), keypoints, descriptors);
      const auto t2 = std::chrono::steady_clock::now();
      auto pooled_features = pooled->extract(image);
      const auto t3 = std::chrono::steady_clock::now();
      if (!features) return fail(kCommand, features.error().message, 1);
      if (!pooled_features) return fail(kCommand, pooled_features.error().message, 1);
      ours_ms.push_back(ms_between(t0, t1));
      cv_ms.push_back(ms_between(t1, t2));
      pooled_ms.push_back(ms_between(t2, t3));
      ours_kps += static_cast<double>(features->keypoints.size());
      pooled_kps += static_cast<double>(pooled_features->keypoints.size());
      cv_kps += static_cast<double>(keypoints.size());
    }
  }
  const auto a = slam::summarize(ours_ms);
  const auto b = slam::summarize(cv_ms);
  const auto c = slam::summarize(pooled_ms);
  const double n = static_cast<double>(std::max<std::size_t>(1, ours_ms.size()));
  const bool partial = done < frames;
  std::printf("bench features: %s, %d frames%s x %d, %dx%d, %d features, %d levels, scale %.2f\n",
              (*source)->name().c_str(), done, partial ? " (interrupted: partial)" : "", args.repeats,
              size.width, size.height, orb.n_features, orb.n_levels, orb.scale_factor);
  std::printf("%-26s %9s %9s %9s %11s\n", "extractor", "p50 ms", "p99 ms", "mean ms", "keypoints");
  std::printf("%-26s %9.2f %9.2f %9.2f %11.0f\n", "sitepose OrbExtractor", a.p50_ms, a.p99_ms, a.mean_ms,
              ours_kps / n);
  const std::string pooled_name = "  levels on pool of " + std::to_string(pool.n_workers());
  std::printf("%-26s %9.2f %9.2f %9.2f %11.0f\n", pooled_name.c_str(), c.p50_ms, c.p99_ms, c.mean_ms,
              pooled_kps / n);
  std::printf("%-26s %9.2f %9.2f %9.2f %11.0f\n", "cv::ORB", b.p50_ms, b.p99_ms, b.mean_ms, cv_kps / n);
  std::printf("OpenCV threads %d (cv::ORB and OpenCV calls inside OrbExtractor may use them)\n",
              cv::getNumThreads());
  std::printf("ratio OrbExtractor / cv::ORB (p50): %.2f; with the pool: %.2f\n",
              b.p50_ms > 0.0 ? a.p50_ms / b.p50_ms : 0.0, b.p50_ms > 0.0 ? c.p50_ms / b.p50_ms : 0.0);
  return partial ? report_interrupted(kCommand, "printed the figures of the frames done") : 0;
}

void add_options(CLI::App& sub, Args& args) {
  add_frame_source_options(sub, args.input, "sitepose YAML config (its orb section is used)");
  sub.add_option("--frames", args.frames, "Frames (0 = all)")->capture_default_str();
  sub.add_option("--repeats", args.repeats, "Extractions per frame and extractor")->capture_default_str();
  sub.add_option("--pool-workers", args.pool_workers,
                 "Worker threads of the pool the pooled extractor's levels run on (plus the caller)")
      ->capture_default_str();
}

const CommandRegistrar kBenchFeatures{make_command<Args>(
    "bench", "features", add_options, run,
    "ORB extraction time of the masked grid extractor vs cv::ORB with the same feature count, one run")};

}  // namespace
}  // namespace sitepose::cli
