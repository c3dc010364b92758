// Issue 24 "repeatable features": with tracking.keep_tracked_corners the
// extractor keeps the corners the last frame matched (found near their
// predicted projections) before spreading the rest of the budget, so the
// tracker matches its close points again instead of making new ones. On a
// parallel rendering (mode full) the close-point repeatability must rise
// clearly and the keyframes fall, with the pose still right; with
// tracking.keyframe_travel_depth_share the travel brings keyframes back.
// Figures over 12 renderings at 960x540: docs/tracking/extraction.md; at
// the cameras' 30 frames/s: docs/tracking/issue24-measurements.md.

#include <gtest/gtest.h>

#include <cstdio>
#include <optional>

#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::experiments {
namespace {

struct Figures {
  double repeatability = 0.0;
  int keyframes = 0;
  double ate_m = 0.0;
  double coverage_ok = 0.0;
  int frames = 0;
};

// Mode full on parallel seed 4 at 640x360: 150 frames at the scenario's 6
// frames/s, or `frames` at `fps`.
Figures run_parallel_with(const config::SiteposeConfig& config, int frames = 150,
                          std::optional<double> fps = std::nullopt) {
  auto source = open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/parallel.yaml", frames, /*seed=*/4, 640,
                               360, fps);
  EXPECT_TRUE(source.has_value()) << source.error().message;
  if (!source) return {};
  auto run = run_dynamic(**source, config);
  EXPECT_TRUE(run.has_value()) << run.error().message;
  if (!run || !run->evaluation) return {};
  const tracking::TrackerCounters& c = run->tracker_counters;
  Figures f;
  f.repeatability =
      c.close_points_previous > 0 ? double(c.close_points_rematched) / double(c.close_points_previous) : 0.0;
  f.keyframes = c.keyframes_created;
  f.ate_m = run->ate_m();
  f.coverage_ok = run->coverage_ok();
  f.frames = run->frames;
  std::printf(
      "keep_tracked_corners %d, keyframe_travel_depth_share %.2f, %d frames at %.0f frames/s: close-point "
      "repeatability %.3f, keyframes %d, ATE %.4f m, OK %.1f %%\n",
      config.tracking.keep_tracked_corners ? 1 : 0, config.tracking.keyframe_travel_depth_share, f.frames,
      (*source)->fps(), f.repeatability, f.keyframes, f.ate_m, 100.0 * f.coverage_ok);
  return f;
}

Figures run_parallel(bool keep_tracked_corners, double keyframe_travel_depth_share = 0.0) {
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kFull;
  config.tracking.keep_tracked_corners = keep_tracked_corners;
  config.tracking.keyframe_travel_depth_share = keyframe_travel_depth_share;
  return run_parallel_with(config);
}

TEST(KeepTrackedCorners, CloseCornersAreMatchedAgainWithFewerKeyframes) {
  const Figures off = run_parallel(false);
  const Figures on = run_parallel(true);
  EXPECT_GT(on.repeatability, off.repeatability + 0.05);
  EXPECT_LT(on.keyframes, off.keyframes);
  EXPECT_LT(on.ate_m, 0.03);
  EXPECT_GE(on.coverage_ok, off.coverage_ok);
}

TEST(KeepTrackedCorners, TravelRuleAddsTheKeyframesKeptPointsNoLongerAskFor) {
  // A tracker that keeps its points makes few keyframes by the ORB-SLAM2
  // rules; keyframe_travel_depth_share asks for one per 5 % of the scene
  // depth travelled (docs/tracking/extraction.md).
  const Figures kept = run_parallel(true);
  const Figures travel = run_parallel(true, 0.05);
  EXPECT_GT(travel.keyframes, kept.keyframes);
  EXPECT_LT(travel.ate_m, 0.03);
  EXPECT_GE(travel.coverage_ok, 0.95);
}

TEST(KeepTrackedCorners, AtTheCamerasRateAKeyframeComesAtMostEveryFifthFrame) {
  // Issue 24: at most one keyframe in 5 frames while driving. The keyframe
  // rules follow the distance driven (the travel rule: 5 % of the scene
  // depth), so at the scenarios' 6 frames/s, 0.13 m a frame, parallel makes
  // one in about 2; at 30 frames/s one in about 10 (shipped defaults).
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kFull;
  const Figures f = run_parallel_with(config, 300, 30.0);
  ASSERT_EQ(f.frames, 300);
  EXPECT_LE(f.keyframes, f.frames / 5);
  EXPECT_LT(f.ate_m, 0.02);
  EXPECT_DOUBLE_EQ(f.coverage_ok, 1.0);
}

}  // namespace
}  // namespace sitepose::experiments
