// The loop closer end to end (detection, verification, correction,
// essential graph, global BA) on the synthetic drifted return of
// experiments/synthetic_loop.hpp: 40 m along a textured wall and back, the
// return's odometry drifting; back at the start only place recognition can
// join the two passes.

#include "sitepose/loop/loop_closer.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include "sitepose/experiments/synthetic_loop.hpp"
#include "sitepose/testing/cameras.hpp"

namespace sitepose::loop {
namespace {

constexpr int kLaneKeyFrames = 41;  // one a metre, 0 .. 40 m

using experiments::DriftedReturn;
using experiments::keyframe_error_m;
using experiments::return_rms_error_m;

StereoCamera test_camera() { return testing::centred_camera(640, 360, 500.0, 0.5); }

DriftedReturn make_loop_map(std::uint64_t wall_seed) {
  return experiments::make_drifted_return(test_camera(), experiments::make_textured_wall(wall_seed, 40.0),
                                          kLaneKeyFrames);
}

std::shared_ptr<const placerec::Vocabulary> vocabulary_of(const map::MapData& m) {
  auto vocabulary = experiments::vocabulary_of(m);
  EXPECT_TRUE(vocabulary.has_value()) << vocabulary.error().message;
  return *vocabulary;
}

struct ClosedLoopRun {
  LoopClosingStats stats;
  map::MapData after;
  std::vector<KeyFramePair> loops;
  bool tracker_correction = false;
  double start_error_m = 0.0;  // the last returning keyframe, back at the start
  double rms_error_m = 0.0;    // over the returning keyframes
};

// `threaded`: on the closer's own thread (start / wait_until_idle / stop),
// as with the mapper thread; else inline (process_pending).
ClosedLoopRun close_loops(const DriftedReturn& lm, const LoopCloserParams& params, bool threaded = false) {
  const auto vocabulary = vocabulary_of(lm.map);
  placerec::KeyFrameDatabase database(vocabulary);
  database.rebuild(lm.map);
  map::SharedMap shared;
  shared.write([&](map::MapData& m) { m = lm.map; });
  LoopCloser closer(test_camera(), shared, database, {}, params);
  if (threaded) closer.start();
  for (map::KeyFrameId id : lm.inbound) closer.enqueue(id);
  if (threaded) {
    closer.wait_until_idle();
    closer.stop();
  } else {
    EXPECT_TRUE(closer.process_pending().has_value());
  }
  ClosedLoopRun run;
  run.stats = closer.stats();
  run.after = shared.read([](const map::MapData& m) { return m; });
  run.loops = closer.loops();
  run.tracker_correction = closer.take_tracker_correction().has_value();
  run.start_error_m = keyframe_error_m(run.after, lm.inbound.back(), lm.inbound_truth.back());
  run.rms_error_m = return_rms_error_m(run.after, lm);
  const LoopClosingStats& stats = run.stats;
  std::printf(
      "loop closer (global BA %s): %lld loops closed, %lld refused; return keyframes' RMS error %.4f m, at "
      "the "
      "start %.4f m; detection %.2f ms mean, verification max %.1f ms, last correction %.1f ms, last pose "
      "graph %d keyframes, %d edges, %.1f ms; %lld global BAs, last %d keyframes, %d points, %.1f ms; "
      "longest write lock %.1f ms\n",
      params.global_ba ? "on" : "off", static_cast<long long>(stats.loops_closed),
      static_cast<long long>(stats.loops_refused), run.rms_error_m, run.start_error_m,
      stats.total_detection_ms / static_cast<double>(stats.keyframes_checked), stats.max_verification_ms,
      stats.last_correction_ms, stats.last_graph_nodes, stats.last_graph_edges, stats.last_optimisation_ms,
      static_cast<long long>(stats.global_ba_runs), stats.last_global_ba_keyframes,
      stats.last_global_ba_points, stats.last_global_ba_ms, stats.max_write_lock_ms);
  return run;
}

TEST(LoopCloser, ClosesADriftedReturnAndLowersItsError) {
  const DriftedReturn lm = make_loop_map(21);
  const double before_m = keyframe_error_m(lm.map, lm.inbound.back(), lm.inbound_truth.back());
  const double rms_before_m = return_rms_error_m(lm.map, lm);
  const SE3 first_before = lm.map.keyframe(lm.map.first_keyframe())->T_world_cam;
  std::printf("before: return keyframes' RMS error %.4f m, at the start %.4f m\n", rms_before_m, before_m);
  EXPECT_GT(before_m, 0.3) << "the synthetic drift is too small to test anything";

  LoopCloserParams pose_graph_only;
  pose_graph_only.global_ba = false;
  const ClosedLoopRun graph = close_loops(lm, pose_graph_only);
  EXPECT_GE(graph.stats.loops_closed, 1);
  EXPECT_EQ(graph.stats.global_ba_runs, 0);
  EXPECT_LT(graph.start_error_m, before_m / 5.0);
  EXPECT_LT(graph.rms_error_m, rms_before_m / 2.5);

  // The global BA refines what the pose graph spread: the observations are
  // exact here, so it lands on the truth.
  const ClosedLoopRun full = close_loops(lm, {});
  EXPECT_GE(full.stats.loops_closed, 1);
  EXPECT_EQ(full.stats.global_ba_runs, full.stats.loops_closed);
  EXPECT_EQ(full.stats.global_ba_stopped, 0);
  EXPECT_LT(full.stats.last_global_ba_final_cost, full.stats.last_global_ba_initial_cost + 1e-9);
  EXPECT_LT(full.start_error_m, 0.01);
  EXPECT_LT(full.rms_error_m, graph.rms_error_m / 10.0);

  for (const ClosedLoopRun* run : {&graph, &full}) {
    EXPECT_EQ(run->after.keyframe(run->after.first_keyframe())->T_world_cam.matrix(), first_before.matrix());
    ASSERT_FALSE(run->loops.empty());
    for (const auto& [current, loop] : run->loops) {
      // Each loop joins a returning keyframe to an outbound one.
      EXPECT_NE(std::find(lm.inbound.begin(), lm.inbound.end(), current), lm.inbound.end());
      EXPECT_NE(std::find(lm.outbound.begin(), lm.outbound.end(), loop), lm.outbound.end());
      // ... and stays in the map for the next loops (and the map file).
      EXPECT_EQ(run->after.keyframe(current)->loop_edges.count(loop), 1U);
      EXPECT_EQ(run->after.keyframe(loop)->loop_edges.count(current), 1U);
      // The corrected keyframe lies on the outbound map now: its drift
      // term's distance is that place's, not the way out and back.
      const map::KeyFrame& closed = *run->after.keyframe(current);
      const map::KeyFrame& old_side = *run->after.keyframe(loop);
      std::printf("loop %lld -> %lld: map travel %.1f -> %.1f m (the loop keyframe's %.1f m)\n",
                  static_cast<long long>(current), static_cast<long long>(loop),
                  lm.map.keyframe(current)->map_travel_m, closed.map_travel_m, old_side.map_travel_m);
      EXPECT_LT(closed.map_travel_m, lm.map.keyframe(current)->map_travel_m);
      EXPECT_NEAR(closed.map_travel_m,
                  old_side.map_travel_m + (closed.camera_center() - old_side.camera_center()).norm(), 1.0);
    }
    EXPECT_TRUE(run->tracker_correction);
  }
}

// The closer's thread (and the global BA on it) closes the same loops as
// the inline run; under ThreadSanitizer (preset tsan) this is the thread's
// race check.
TEST(LoopCloser, ClosesTheSameLoopsOnItsOwnThread) {
  const DriftedReturn lm = make_loop_map(21);
  const ClosedLoopRun inline_run = close_loops(lm, {});
  const ClosedLoopRun threaded_run = close_loops(lm, {}, true);
  EXPECT_EQ(threaded_run.stats.loops_closed, inline_run.stats.loops_closed);
  EXPECT_EQ(threaded_run.stats.global_ba_runs, inline_run.stats.global_ba_runs);
  EXPECT_EQ(threaded_run.loops, inline_run.loops);
  EXPECT_NEAR(threaded_run.start_error_m, inline_run.start_error_m, 1e-6);
}

// The same drive without drift and with the return's points those of the
// outbound pass: the map is one covisible cluster, nothing to close.
TEST(LoopCloser, LeavesAConnectedMapAlone) {
  const experiments::TexturedWall w = experiments::make_textured_wall(22, 40.0);
  map::MapData m;
  std::vector<map::PointId> ids(w.p_world_m.size(), map::kNoPoint);
  const auto keyframe_at = [&](double x_m) {
    const SE3 T = experiments::lane_camera_at(x_m);
    experiments::insert_wall_keyframe(m, test_camera(), w, T, T, ids);
  };
  for (int k = 0; k < kLaneKeyFrames; ++k) keyframe_at(k);
  for (int k = kLaneKeyFrames - 2; k >= 0; --k) keyframe_at(k);
  for (const auto& [pid, p] : m.points()) m.update_point_appearance(pid);
  const auto vocabulary = vocabulary_of(m);
  placerec::KeyFrameDatabase database(vocabulary);
  database.rebuild(m);
  map::SharedMap shared;
  shared.write([&](map::MapData& data) { data = m; });
  LoopCloser closer(test_camera(), shared, database, {});
  for (const auto& [id, kf] : m.keyframes()) closer.enqueue(id);
  ASSERT_TRUE(closer.process_pending().has_value());
  EXPECT_EQ(closer.stats().loops_closed, 0);
  EXPECT_EQ(closer.stats().global_ba_runs, 0);
  EXPECT_FALSE(closer.take_tracker_correction().has_value());
}

}  // namespace
}  // namespace sitepose::loop
