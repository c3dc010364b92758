// Issue 19's blind spells over three renderings (seeds) each, beside the
// scenarios' own in blackout_test.cpp; figures per seed for the note.
// Minutes: label sweep.

#include <gtest/gtest.h>

#include "blind_spell_run.hpp"

namespace sitepose::experiments {
namespace {

using blind_spell::BlackoutRun;
using blind_spell::run_blackout;
using blind_spell::run_truckstop;
using blind_spell::TruckstopRun;

constexpr int kSeeds[] = {1, 2, 3};

// Measured on main (7d6f168): back after 0, 0, 1 frames; OK on 97.5, 97.5,
// 96.2 % of the frames with a view; ATE 0.0092, 0.0138, 0.0096 m; largest
// OK error 0.026, 0.045, 0.023 m.
TEST(BlackoutSweep, EverySeedRelocalisesAndNeverReportsAWrongPoseOk) {
  for (const int seed : kSeeds) {
    BlackoutRun b;
    ASSERT_NO_FATAL_FAILURE(run_blackout(b, seed));
    EXPECT_GE(b.score.frames_to_relocalise, 0) << "seed " << seed << ": never relocalised";
    EXPECT_LT(b.score.frames_to_relocalise, 5) << "seed " << seed;
    EXPECT_GE(b.coverage, 0.95) << "seed " << seed;
    EXPECT_LE(b.run.evaluation->ate_m.rmse, 0.02) << "seed " << seed;
    EXPECT_EQ(b.score.ok_frames_off, 0) << "seed " << seed << ": largest OK error " << b.score.max_ok_error_m;
  }
}

// Disabled: open defect (issue 19; see blackout_test.cpp). Measured on main
// (7d6f168), seeds 1, 2, 3: OK on 76.5, 98.5, 83.8 % of the frames with a
// view; ATE 1.387, 0.013, 0.251 m; OK poses > 0.05 m off: 4, 0, 1 (largest
// 0.053, 0.037, 0.052 m). With the map-aware hold: no OK pose > 0.05 m off
// on any seed, but the relocalised pose stays RECOVERING (coverage 50.0 %
// each, ATE 0.028, 0.024, 0.037 m): still disabled for coverage and ATE.
TEST(BlackoutSweep, DISABLED_TruckstopEverySeedComesBackRightOrNotOk) {
  for (const int seed : kSeeds) {
    TruckstopRun t;
    ASSERT_NO_FATAL_FAILURE(run_truckstop(t, seed));
    EXPECT_EQ(t.score.ok_frames_off, 0) << "seed " << seed << ": largest OK error " << t.score.max_ok_error_m;
    EXPECT_LT(t.score.frames_to_relocalise, 5) << "seed " << seed;
    EXPECT_GE(t.coverage, 0.95) << "seed " << seed;
    EXPECT_LE(t.run.evaluation->ate_m.rmse, 0.02) << "seed " << seed;
  }
}

// The repeated pattern's twin (Blackout.TruckstopNeverReportsARepeatedPatternsTwinOk)
// and the truck's arrival (Blackout.TheTrucksArrivalNeverGivesAWrongOkPose)
// over 20 renderings at 640x360: before finds_distant_background, 9 of them
// came back 8.2 m off and reported it OK for 3-26 frames (162 OK poses off
// after the view returned); before kMinOkCloseInliers, 4 reported the
// arrival OK 0.052-0.090 m off. Every OK pose of the run is scored.
TEST(BlackoutSweep, TruckstopTwentySeedsAt640x360NeverReportAWrongPoseOk) {
  for (int seed = 1; seed <= 20; ++seed) {
    TruckstopRun t;
    ASSERT_NO_FATAL_FAILURE(run_truckstop(t, seed, 640, 360));
    EXPECT_EQ(t.score.ok_frames_off, 0)
        << "seed " << seed << ": largest error of an OK pose: " << t.score.max_ok_error_m << " m";
  }
}

// The provisional map (provisional_map_test.cpp) over three renderings.
TEST(BlackoutSweep, LostMapEverySeedJoinsAndNeverReportsAWrongPoseOk) {
  for (const int seed : {13, 14, 15}) {
    blind_spell::LostMapRun r;
    ASSERT_NO_FATAL_FAILURE(blind_spell::run_lostmap(r, seed));
    EXPECT_EQ(r.run.tracker_counters.provisional_maps_joined, 1) << "seed " << seed;
    EXPECT_LT(r.run.tracker_counters.largest_join_rotation_deg, 1.5) << "seed " << seed;
    EXPECT_EQ(r.score.ok_frames_off, 0) << "seed " << seed << ": largest OK error " << r.score.max_ok_error_m;
    EXPECT_EQ(r.ok_after_visible, r.frames_after_join) << "seed " << seed;
  }
}

// Blackout.AtSpeedTheFramesAfterARelocalisationAreRight over three renderings.
TEST(BlackoutSweep, LostMapWithoutProvisionalMapsNeverReportsAWrongPoseOk) {
  for (const int seed : {13, 14, 15}) {
    blind_spell::LostMapRun r;
    ASSERT_NO_FATAL_FAILURE(blind_spell::run_lostmap(r, seed, false));
    EXPECT_EQ(r.score.ok_frames_off, 0) << "seed " << seed << ": largest OK error " << r.score.max_ok_error_m;
    EXPECT_GT(r.first_ok_after, 0) << "seed " << seed << ": never OK again";
    EXPECT_EQ(r.ok_after_visible, r.frames_after_join) << "seed " << seed;
  }
}

}  // namespace
}  // namespace sitepose::experiments
