// The loop closer end to end (detection, verification, correction,
// essential graph) on a synthetic map with a real loop in it: a camera
// drives 40 m along a textured wall and back. Out, the map is exact; at
// the turn the return still sees the outbound points, after it the
// association is lost and the return builds its own (duplicate) points
// from odometry that drifts 0.1 degrees of heading and 1 cm a keyframe.
// Back at the start, only place recognition can join the two. The
// keyframes' observations are exact, so a global BA after the pose graph
// can find the truth.

#include "sitepose/loop/loop_closer.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "sitepose/testing/cameras.hpp"

namespace sitepose::loop {
namespace {

constexpr int kLaneKeyFrames = 41;  // one a metre, 0 .. 40 m

StereoCamera test_camera() { return testing::centred_camera(640, 360, 500.0, 0.5); }

struct World {
  std::vector<Eigen::Vector3d> p;
  std::vector<map::Descriptor> d;
};

World make_wall(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-8.0, 48.0), uy(-2.0, 2.0), uz(6.0, 10.0);
  World w;
  for (int i = 0; i < 6000; ++i) {
    w.p.emplace_back(ux(rng), uy(rng), uz(rng));
    map::Descriptor d;
    for (auto& b : d) b = static_cast<std::uint8_t>(rng() & 0xFF);
    w.d.push_back(d);
  }
  return w;
}

SE3 camera_at(double x_m) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x_m, 0.0, 0.0)); }

// Odometry's error of one keyframe step (body frame): 1 cm forward and
// 0.1 degrees of heading.
SE3 step_error() {
  Vector6d xi;
  xi << 0.01, 0.0, 0.0, 0.0, 0.1 * M_PI / 180.0, 0.0;
  return SE3::exp(xi);
}

// Inserts a keyframe truly at T_true, stored at T_map; `id_of` maps a world
// point to its map point on this side (created here, at T_map's view of
// the point, when missing).
map::KeyFrameId insert_keyframe(map::MapData& m, const World& w, const SE3& T_true, const SE3& T_map,
                                std::vector<map::PointId>& id_of) {
  const StereoCamera camera = test_camera();
  map::KeyFrame kf;
  kf.T_world_cam = T_map;
  std::vector<int> world_of_keypoint;
  for (std::size_t i = 0; i < w.p.size(); ++i) {
    const Eigen::Vector3d p_cam = T_true.inverse() * w.p[i];
    if (!(p_cam.z() > 0.5) || !camera.in_image(camera.project(p_cam), 2.0)) continue;
    map::KeyPointData kp;
    kp.uv_px = camera.project(p_cam);
    kp.u_right_px = camera.project_right_u(p_cam);
    kp.depth_m = p_cam.z();
    kp.descriptor = w.d[i];
    kf.keypoints.push_back(kp);
    kf.point_of_keypoint.push_back(id_of[i]);
    world_of_keypoint.push_back(static_cast<int>(i));
  }
  const map::KeyFrameId id = m.add_keyframe(kf);
  for (std::size_t k = 0; k < world_of_keypoint.size(); ++k) {
    const auto i = static_cast<std::size_t>(world_of_keypoint[k]);
    if (id_of[i] != map::kNoPoint) continue;
    id_of[i] = m.add_point(T_map * (T_true.inverse() * w.p[i]), id, static_cast<int>(k));
  }
  return id;
}

struct LoopMap {
  map::MapData map;
  std::vector<map::KeyFrameId> outbound;
  std::vector<map::KeyFrameId> inbound;
  std::vector<SE3> inbound_truth;
};

LoopMap make_loop_map(const World& w) {
  LoopMap lm;
  std::vector<map::PointId> outbound_ids(w.p.size(), map::kNoPoint);
  for (int k = 0; k < kLaneKeyFrames; ++k) {
    lm.outbound.push_back(insert_keyframe(lm.map, w, camera_at(k), camera_at(k), outbound_ids));
  }
  std::vector<map::PointId> inbound_ids(w.p.size(), map::kNoPoint);
  SE3 T_map = camera_at(kLaneKeyFrames - 2);  // the first returning keyframe, still exact
  for (int r = 1; r < kLaneKeyFrames; ++r) {
    const SE3 T_true = camera_at(kLaneKeyFrames - 1 - r);
    // Dead reckoning from the turn: the true step, then its error.
    if (r >= 2) T_map = T_map * camera_at(-1.0) * step_error();
    // At the turn the return still matches the outbound points; one
    // keyframe later half of them, then none.
    std::vector<map::PointId> ids = outbound_ids;
    if (r >= 2) {
      for (std::size_t i = 0; i < w.p.size(); ++i) {
        if (r > 2 || i % 2 == 1) ids[i] = inbound_ids[i];
      }
    }
    lm.inbound.push_back(insert_keyframe(lm.map, w, T_true, T_map, ids));
    if (r >= 2) {
      for (std::size_t i = 0; i < w.p.size(); ++i) {
        if (ids[i] != outbound_ids[i]) inbound_ids[i] = ids[i];
      }
    }
    lm.inbound_truth.push_back(T_true);
  }
  for (const auto& [pid, p] : lm.map.points()) lm.map.update_point_appearance(pid);
  for (const auto& [id, kf] : lm.map.keyframes()) lm.map.update_connections(id);
  return lm;
}

std::shared_ptr<const placerec::Vocabulary> vocabulary_of(const map::MapData& m) {
  std::vector<cv::Mat> images;
  for (const auto& [id, kf] : m.keyframes()) {
    cv::Mat d(static_cast<int>(kf.keypoints.size()), 32, CV_8UC1);
    for (int r = 0; r < d.rows; ++r)
      std::memcpy(d.ptr(r), kf.keypoints[static_cast<std::size_t>(r)].descriptor.data(), 32);
    images.push_back(d);
  }
  placerec::VocabularyParams params;
  params.levels = 3;
  auto v = placerec::Vocabulary::train(images, params);
  EXPECT_TRUE(v.has_value());
  return std::make_shared<const placerec::Vocabulary>(std::move(*v));
}

double error_m(const map::MapData& m, map::KeyFrameId id, const SE3& truth) {
  return (m.keyframe(id)->T_world_cam.translation() - truth.translation()).norm();
}

struct ClosedLoopRun {
  LoopClosingStats stats;
  map::MapData after;
  std::vector<KeyFramePair> loops;
  bool tracker_correction = false;
  double start_error_m = 0.0;  // the last returning keyframe, back at the start
  double rms_error_m = 0.0;    // over the returning keyframes
};

double rms_error_m(const map::MapData& m, const LoopMap& lm) {
  double sum = 0.0;
  for (std::size_t r = 0; r < lm.inbound.size(); ++r) {
    sum += std::pow(error_m(m, lm.inbound[r], lm.inbound_truth[r]), 2);
  }
  return std::sqrt(sum / static_cast<double>(lm.inbound.size()));
}

// `threaded`: on the closer's own thread (start / wait_until_idle / stop),
// as with the mapper thread; else inline (process_pending).
ClosedLoopRun close_loops(const LoopMap& lm, const LoopCloserParams& params, bool threaded = false) {
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
  run.start_error_m = error_m(run.after, lm.inbound.back(), lm.inbound_truth.back());
  run.rms_error_m = rms_error_m(run.after, lm);
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
  const World w = make_wall(21);
  const LoopMap lm = make_loop_map(w);
  const double before_m = error_m(lm.map, lm.inbound.back(), lm.inbound_truth.back());
  const double rms_before_m = rms_error_m(lm.map, lm);
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
    }
    EXPECT_TRUE(run->tracker_correction);
  }
}

// The closer's thread (and the global BA on it) closes the same loops as
// the inline run; under ThreadSanitizer (preset tsan) this is the thread's
// race check.
TEST(LoopCloser, ClosesTheSameLoopsOnItsOwnThread) {
  const LoopMap lm = make_loop_map(make_wall(21));
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
  const World w = make_wall(22);
  map::MapData m;
  std::vector<map::PointId> ids(w.p.size(), map::kNoPoint);
  for (int k = 0; k < kLaneKeyFrames; ++k) insert_keyframe(m, w, camera_at(k), camera_at(k), ids);
  for (int k = kLaneKeyFrames - 2; k >= 0; --k) insert_keyframe(m, w, camera_at(k), camera_at(k), ids);
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
