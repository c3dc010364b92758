// Issue 19: the lens is covered (near-black frames) for 10 frames while the
// roller drives 1.3 m on (scenario blackout), and a truck stands 1.75 m in
// front of the lens for 5 s (scenario truckstop). A pose after the blind
// spell must be right or not OK: relocalisation within 5 frames of the
// view's return, coverage >= 95 % of the frames with a view, ATE <= 0.02 m,
// and no OK pose more than 0.05 m from the ground truth (every OK pose is
// scored). The same at 3 m/s past the end of the map (scenario lostmap,
// provisional maps off).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "blind_spell_run.hpp"

namespace sitepose::experiments {
namespace {

using blind_spell::BlackoutRun;
using blind_spell::BlackoutScore;
using blind_spell::run_blackout;
using blind_spell::run_truckstop;
using blind_spell::TruckstopRun;

TEST(Blackout, RelocalisesAndNeverReportsAWrongPoseOk) {
  BlackoutRun b;
  ASSERT_NO_FATAL_FAILURE(run_blackout(b));
  const BlackoutScore& s = b.score;
  EXPECT_GE(s.frames_to_relocalise, 0) << "never relocalised";
  EXPECT_LT(s.frames_to_relocalise, 5);
  EXPECT_GE(b.coverage, 0.95);
  EXPECT_LE(b.run.evaluation->ate_m.rmse, 0.02);
  EXPECT_EQ(s.ok_frames_off, 0) << "largest error of an OK pose: " << s.max_ok_error_m << " m";
}

// The safety half: no OK pose more than 0.05 m off. (Before OK required a
// precise pose, relocalisation after the truck landed 2.76 m off on distant
// points only and reported OK from then on.)
TEST(Blackout, TruckInFrontOfTheLensNeverGivesAWrongOkPose) {
  TruckstopRun t;
  ASSERT_NO_FATAL_FAILURE(run_truckstop(t));
  EXPECT_EQ(t.score.ok_frames_off, 0) << "largest error of an OK pose: " << t.score.max_ok_error_m << " m";
}

// A repeated pattern's twin. The simulator's ground tiles repeat every
// 8.192 m, and so do its signs and site offices. At 640x360, 9 of truckstop
// seeds 1-20 came back 8.2 m off after the truck and reported it OK for 3-26
// frames: seed 3 by a relocalisation, seed 9 by joining its provisional map
// to the twin (5 agreeing frames). Both found 0.20-0.31 of the map in view,
// but 0.02-0.05 of its distant background; right places 0.20 and more
// (finds_distant_background).
TEST(Blackout, TruckstopNeverReportsARepeatedPatternsTwinOk) {
  for (const int seed : {3, 9}) {
    TruckstopRun t;
    ASSERT_NO_FATAL_FAILURE(run_truckstop(t, seed, 640, 360));
    EXPECT_EQ(t.score.ok_frames_off_after_view, 0)
        << "seed " << seed << ": largest error of an OK pose: " << t.score.max_ok_error_m << " m";
  }
}

// The truck's arrival. As it draws level it hides the near ground, then
// the whole right image: the inliers with a stereo depth of their own fall
// from hundreds to none within 3 frames (about frames 34-37), and the pose
// rests on distant map points alone, at a position sigma under 0.02 m. At
// 640x360 such OK poses were 0.05-0.09 m off in mode full (seeds 6, 12, 15,
// 17 of 1-20) and up to 0.39 m in mode none (seed 3). An OK pose needs
// kMinOkCloseInliers of them (relocaliser.hpp). The truck's arrival is in
// the first 45 frames.
TEST(Blackout, TheTrucksArrivalNeverGivesAWrongOkPose) {
  struct Case {
    int seed;
    config::MaskingMode mode;
  };
  const std::string scenario = std::string(SITEPOSE_SCENARIO_DIR) + "/truckstop.yaml";
  for (const Case c : {Case{6, config::MaskingMode::kFull}, Case{17, config::MaskingMode::kFull},
                       Case{3, config::MaskingMode::kNone}}) {
    auto source = open_simulated(scenario, 45, c.seed, 640, 360);
    ASSERT_TRUE(source.has_value()) << source.error().message;
    config::SiteposeConfig config;
    config.dynamic.mode = c.mode;
    auto run = run_dynamic(**source, config);
    ASSERT_TRUE(run.has_value()) << run.error().message;
    ASSERT_EQ(run->ground_truth.size(), static_cast<std::size_t>(run->frames));
    const BlackoutScore s = blind_spell::score(*run, std::vector<bool>(run->frames, false));
    const int ok_frames =
        static_cast<int>(std::count_if(run->recorder.poses().begin(), run->recorder.poses().end(),
                                       [](const PoseEstimate& p) { return p.state == TrackingState::kOk; }));
    std::printf("truck's arrival (seed %d, mode %s): %d of %d frames OK, largest OK error %.4f m\n", c.seed,
                config::to_string(c.mode), ok_frames, run->frames, s.max_ok_error_m);
    EXPECT_EQ(s.ok_frames_off, 0) << "seed " << c.seed << ", mode " << config::to_string(c.mode)
                                  << ": largest error of an OK pose: " << s.max_ok_error_m << " m";
    // The rule must not take the frames before the truck: they are OK.
    EXPECT_GE(ok_frames, 33) << "seed " << c.seed << ", mode " << config::to_string(c.mode);
  }
}

// truckstop seed 4 at 640x360, mode none (the truck is mapped). A
// provisional map begun on the standing truck was joined to the site map at
// frame 139, 0.08 m off; the hold after the join never confirmed it
// (map-aware sigma 0.07 m) and tracking was lost at frame 148. The
// relocalisation at frame 149 then rested on the joined keyframes' close
// points (map-aware sigma 0.006 m), and frames 151-155 were reported OK
// 0.09-0.13 m off. Joined keyframes now count towards a hold only once the
// hold after their join has ended, and are dropped when tracking is lost
// before that (Tracker::drop_unconfirmed_join).
TEST(Blackout, AJoinThatWasNeverConfirmedGivesNoOkPose) {
  TruckstopRun t;
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  // The path above needs the established map outvoted (a map begun on the
  // truck); with the default trust in it, the provisional map is dropped
  // before any join. The code path stays for any map it does not catch.
  config.tracking.trust_established_map = false;
  ASSERT_NO_FATAL_FAILURE(run_truckstop(t, 4, 640, 360, config));
  const tracking::TrackerCounters& c = t.run.tracker_counters;
  EXPECT_EQ(c.joins_dropped_unconfirmed, 1) << "the join this test is about was not dropped";
  std::printf("joined %d, dropped before their join was confirmed %d, provisional maps dropped %d\n",
              c.provisional_maps_joined, c.joins_dropped_unconfirmed, c.provisional_maps_dropped);
  EXPECT_EQ(t.score.ok_frames_off, 0) << "largest error of an OK pose: " << t.score.max_ok_error_m << " m";
}

// truckstop seed 18 at 640x360, mode none: the truck slides in front of
// the lens and is mapped (a keyframe every frame from 35 to 49, the close
// points coming back on the truck), and with tracking.trust_established_map
// off the pose followed it: 101 OK poses more than 0.05 m off, up to 7.58 m,
// from frame 40. With the option (the default) the fresh points on the truck
// cannot outvote the established map: 35 OK frames, largest error 0.015 m.
TEST(Blackout, ModeNoneNeverFollowsATruckMappedInFrontOfTheLens) {
  TruckstopRun t;
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  ASSERT_NO_FATAL_FAILURE(run_truckstop(t, 18, 640, 360, config));
  EXPECT_EQ(t.score.ok_frames_off, 0) << "largest error of an OK pose: " << t.score.max_ok_error_m << " m";
}

// Scenario lostmap without provisional maps: LOST from the view's return
// (frame 138) until the site map is back in view (about frame 290) at 3 m/s,
// 0.5 m a frame. The frame after a relocalisation has no velocity; searched
// around the last pose it matched the wrong points, the hold confirmed the
// track, and 24 frames were reported OK 2.3-7.1 m off. It is tracked by
// descriptors now (Relocaliser::track_against_keyframe).
TEST(Blackout, AtSpeedTheFramesAfterARelocalisationAreRight) {
  blind_spell::LostMapRun r;
  ASSERT_NO_FATAL_FAILURE(blind_spell::run_lostmap(r, std::nullopt, false));
  EXPECT_EQ(r.run.tracker_counters.provisional_maps_started, 0);
  EXPECT_EQ(r.score.ok_frames_off, 0) << "largest error of an OK pose: " << r.score.max_ok_error_m << " m";
  EXPECT_GT(r.first_ok_after, 250) << "an OK pose before the site map was in view";
  EXPECT_LT(r.first_ok_after, 315) << "relocalised late or never";
  EXPECT_EQ(r.ok_after_visible, r.frames_after_join) << "once held, every frame OK";
}

// Disabled: open defect (issue 19). The map ends where the truck came
// (frame ~39) and the view returns ~5.5 m further on, where the map shares
// only distant points (fence, buildings at ~18 m) with the view, and the
// scene repeats. Here the first relocalisation (frame 121) is 2.7 m off with
// a position sigma of 0.04 m: never OK, but tracked RECOVERING to the end,
// as nothing relocalises again, so coverage after the truck is 0 %. A
// fresh relocalisation in any of frames 122-155 finds the right place
// (0.01-0.1 m off, sigma 0.015-0.022 m). Refusing imprecise relocalisations
// and dropping a hold that stops being precise gives 95.6 % OK and ATE
// 0.019 m here, but on seeds 1 and 3 the relocalised pose is 0.05-0.11 m off
// at a sigma below 0.02 m (the distant points' depth errors, which the
// exact-point sigma does not show), and OK poses > 0.05 m off appear (1 and
// 30 frames; 4 and 1 before). A map-aware sigma (point depth error
// propagated) refuses the right places too and still accepts a repeated
// twin 8.2 m off on seed 3: candidates need an ambiguity test (two distinct
// precise places -> refuse) and the pose a bias bound before this can pass.
// Both are in now (relocaliser.cpp, Tracker::judge_hold): no OK pose > 0.05
// m off on seeds 1-3 and 12, but the relocalised pose stays RECOVERING
// (map-aware sigma 0.06-0.09 m; its errors reach 0.13 m), so coverage after
// the truck is still 0 % (50.0 % of the visible frames, ATE 0.033 m here).
TEST(Blackout, DISABLED_TruckInFrontOfTheLensRelocalisesWithin5Frames) {
  TruckstopRun t;
  ASSERT_NO_FATAL_FAILURE(run_truckstop(t));
  EXPECT_GE(t.score.frames_to_relocalise, 0) << "never relocalised";
  EXPECT_LT(t.score.frames_to_relocalise, 5);
  EXPECT_GE(t.coverage, 0.95);
  EXPECT_LE(t.run.evaluation->ate_m.rmse, 0.02);
}

}  // namespace
}  // namespace sitepose::experiments
