// Issue 19: a long back-and-forth with machines passing and parking
// (scenario backforth-site, seed 11, 640x360, all 2160 frames = 360 s,
// mode full with the labels detector, mapper inline). The strip is driven
// ten times; the tracker must meet the keyframes of the first passes again
// rather than map the strip anew. Minutes: label sweep.

#include <gtest/gtest.h>

#include <cstdio>

#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::experiments {
namespace {

// Measured on main (f6292a7), 83 s on an idle machine: every frame OK, ATE
// 0.0048 m (largest 0.0106 m), 150 keyframes made and 40 left in the map,
// 66.6 % of the matches to points of keyframes 60 s old or more. Before
// f6292a7 the travel rule re-mapped the strip every pass: 568 keyframes
// made, 38.4 % (docs/placerec/README.md).
TEST(SiteMapSweep, ALongBackAndForthWithMachinesMeetsItsOldKeyframesAgain) {
  auto source = open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/backforth-site.yaml", 0, 11, 640, 360);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  const config::SiteposeConfig config;  // mode full, labels detector
  auto run = run_dynamic(**source, config);
  ASSERT_TRUE(run.has_value()) << run.error().message;
  const tracking::TrackerCounters& counters = run->tracker_counters;
  ASSERT_GT(counters.matches, 0);
  const double old_share =
      static_cast<double>(counters.matches_from_old_keyframes) / static_cast<double>(counters.matches);
  std::printf(
      "[figures] backforth-site seed 11: %d frames, OK %.1f %%, ATE %.4f m (largest %.4f m), "
      "keyframes made %d, in the map %zu, matches to points of keyframes >= 60 s old %.1f %%\n",
      run->frames, 100.0 * run->coverage_ok(), run->ate_m(), run->ate_max_m(), counters.keyframes_created,
      run->keyframes, 100.0 * old_share);
  EXPECT_EQ(run->frames, 2160);
  EXPECT_GE(run->coverage_ok(), 0.99);
  EXPECT_GE(old_share, 0.6);
  EXPECT_LE(counters.keyframes_created, 300) << "the strip is mapped again";
  EXPECT_LE(run->keyframes, 60U) << "the map grows with time, not with the strip";
  EXPECT_LE(run->ate_m(), 0.015);
}

}  // namespace
}  // namespace sitepose::experiments
