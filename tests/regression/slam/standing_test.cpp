// Issue 24 "robust when standing": the ego stands while a truck passes
// close and hides most of the view. Mode none (no detector), with
// tracking.trust_established_map on (the default), must not follow
// the truck: no OK pose more than 0.05 m from the ground truth, ATE <= 0.02
// m, and OK again at the right place once the truck has passed. Rendered at
// low resolution, where the background left beside the truck holds fewest
// points (main before this test: standing seed 21 at 480x270 followed the
// truck 2.3 m with every pose OK, standing-close 3.0 m; figures in
// docs/tracking/standing.md).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::experiments {
namespace {

struct Case {
  const char* scenario;
  int seed;
  int width;
  int height;
};

class StandingEgo : public ::testing::TestWithParam<Case> {};

TEST_P(StandingEgo, ModeNoneNeverFollowsThePassingTruck) {
  const Case c = GetParam();
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  auto source = open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/" + c.scenario + ".yaml", 0, c.seed,
                               c.width, c.height);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  auto run = run_dynamic(**source, config);
  ASSERT_TRUE(run.has_value()) << run.error().message;
  ASSERT_TRUE(run->evaluation.has_value()) << run->evaluation_error;
  const auto& poses = run->recorder.poses();
  ASSERT_EQ(run->ground_truth.size(), poses.size());
  double max_ok_error_m = 0.0;
  int ok_off = 0;
  int last_not_ok = -1;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    if (poses[k].state != TrackingState::kOk) {
      last_not_ok = static_cast<int>(k);
      continue;
    }
    const double error_m =
        (poses[k].T_world_cam.translation() - run->ground_truth[k].T_world_cam.translation()).norm();
    max_ok_error_m = std::max(max_ok_error_m, error_m);
    if (error_m > 0.05) ++ok_off;
  }
  std::printf(
      "%s seed %d %dx%d: %d frames, OK %.1f %%, ATE rmse %.4f m, largest OK error %.4f m, "
      "OK poses > 0.05 m off: %d, last frame not OK: %d\n",
      c.scenario, c.seed, c.width, c.height, run->frames, 100.0 * run->coverage_ok(),
      run->evaluation->ate_m.rmse, max_ok_error_m, ok_off, last_not_ok);
  EXPECT_EQ(ok_off, 0) << "largest error of an OK pose: " << max_ok_error_m << " m";
  EXPECT_LE(run->evaluation->ate_m.rmse, 0.02);
  // Not OK only while the truck hides the view (measured 84 % and 80 % OK).
  EXPECT_GE(run->coverage_ok(), 0.75);
  // OK again once the view is back (the last 10 frames).
  EXPECT_LT(last_not_ok, run->frames - 10);
}

INSTANTIATE_TEST_SUITE_P(Renderings, StandingEgo,
                         ::testing::Values(Case{"standing", 21, 480, 270},
                                           Case{"standing-close", 3, 640, 360}),
                         [](const auto& info) {
                           std::string name = info.param.scenario;
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name + "_seed" + std::to_string(info.param.seed);
                         });

}  // namespace
}  // namespace sitepose::experiments
