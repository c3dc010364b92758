// Issue 19: loop closing in the whole system on a simulated back-and-forth
// run (scenario backforth, seed 1, 640x360: 16 m down the lane and back to
// the start, 230 frames), tracked in the deterministic (inline) mode with a
// vocabulary trained at test time on another scenario (static), once with
// loop closing off and once on. Scored against the ground truth with world
// = the first left camera (the first keyframe, which the pose graph holds
// fixed), no alignment: RMS position error of the OK frames (ATE), the
// error at the last frame, back at the start, and the largest OK error.
//
// What it shows: the closer checks every keyframe, and nothing it does
// makes the run worse. On this lane it closes no loop: the far structures
// make every keyframe covisible with every other, so tracking itself keeps
// the old keyframes and there is no disconnected revisit to close (the
// synthetic drifted return of tests/unit/loop/loop_closer_test.cpp is one).
// A false loop accepted here would move the map by metres and fail the
// bounds.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/placerec/vocabulary.hpp"
#include "sitepose/slam/slam_system.hpp"
#include "static_vocabulary.hpp"

namespace sitepose::experiments {
namespace {

const std::string kScenarioDir = SITEPOSE_SCENARIO_DIR;
constexpr int kWidth = 640;
constexpr int kHeight = 360;
constexpr int kFrames = 230;  // out and back (216 frames), then standing at the start

struct Rendered {
  StereoCamera camera;
  double fps = 6.0;
  std::vector<LabelledFrame> frames;
};

void render(Rendered& out, const std::string& scenario = "backforth", int frames = kFrames, int seed = 1) {
  auto source = open_simulated(kScenarioDir + "/" + scenario + ".yaml", frames, seed, kWidth, kHeight);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  out.camera = (*source)->camera();
  out.fps = (*source)->fps();
  for (int i = 0; i < frames; ++i) {
    auto frame = (*source)->read(i);
    ASSERT_TRUE(frame.has_value());
    ASSERT_TRUE(frame->T_world_cam_gt.has_value());
    out.frames.push_back(std::move(*frame));
  }
}

struct BackAndForthRun {
  int ok_frames = 0;
  double ate_m = 0.0;            // RMS over OK frames
  double late_ate_m = 0.0;       // RMS over the OK frames from late_from on
  double return_error_m = -1.0;  // at the last frame (< 0: not OK there)
  double max_ok_error_m = 0.0;
  double error_at_frame_m = -1.0;  // at frame `at_frame` of run_back_and_forth (< 0: not OK there)
  // The same frames re-expressed in the map as the run left it
  // (SlamSystem::poses_in_final_map): RMS over the OK frames, and the
  // error at frame `at_frame` of run_back_and_forth (< 0: not placed).
  double final_ate_m = 0.0;
  double final_error_at_frame_m = -1.0;
  int final_left_out = 0;
  std::vector<PoseEstimate> poses;
  loop::LoopClosingStats loops;
};

void run_back_and_forth(const Rendered& rendered,
                        const std::shared_ptr<const placerec::Vocabulary>& vocabulary, bool loop_closing,
                        BackAndForthRun& out, const char* name = "backforth seed 1",
                        std::size_t late_from = 0, std::size_t at_frame = 0) {
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  config.mapping.loop_closing = loop_closing;
  slam::SlamOptions options;
  options.fps = rendered.fps;
  options.vocabulary = vocabulary;
  options.keep_removed_keyframe_links = true;
  auto system = slam::SlamSystem::create(rendered.camera, config, options);
  ASSERT_TRUE(system.has_value()) << system.error().message;
  const SE3 T_first_world = rendered.frames.front().T_world_cam_gt->inverse();
  double sum_sq = 0.0;
  double late_sum_sq = 0.0;
  int late_frames = 0;
  for (std::size_t i = 0; i < rendered.frames.size(); ++i) {
    const Eigen::Vector3d truth = (T_first_world * *rendered.frames[i].T_world_cam_gt).translation();
    auto report = (*system)->process(rendered.frames[i].frame);
    ASSERT_TRUE(report.has_value()) << report.error().message;
    out.poses.push_back(report->pose);
    if (report->pose.state != TrackingState::kOk) continue;
    const double e = (report->pose.T_world_cam.translation() - truth).norm();
    ++out.ok_frames;
    sum_sq += e * e;
    if (i >= late_from) {
      late_sum_sq += e * e;
      ++late_frames;
    }
    out.max_ok_error_m = std::max(out.max_ok_error_m, e);
    if (i + 1 == rendered.frames.size()) out.return_error_m = e;
    if (i == at_frame) out.error_at_frame_m = e;
  }
  (*system)->finish();
  out.ate_m = out.ok_frames > 0 ? std::sqrt(sum_sq / out.ok_frames) : 0.0;
  out.late_ate_m = late_frames > 0 ? std::sqrt(late_sum_sq / late_frames) : 0.0;
  if (const auto loops = (*system)->loop_stats(); loops) out.loops = *loops;
  const std::vector<std::optional<SE3>> final_poses = (*system)->poses_in_final_map(out.poses);
  double final_sum_sq = 0.0;
  for (std::size_t i = 0; i < out.poses.size(); ++i) {
    if (out.poses[i].state != TrackingState::kOk) continue;
    if (!final_poses[i]) {
      ++out.final_left_out;
      continue;
    }
    const Eigen::Vector3d truth = (T_first_world * *rendered.frames[i].T_world_cam_gt).translation();
    const double e = (final_poses[i]->translation() - truth).norm();
    final_sum_sq += e * e;
    if (i == at_frame) out.final_error_at_frame_m = e;
  }
  const int placed = out.ok_frames - out.final_left_out;
  out.final_ate_m = placed > 0 ? std::sqrt(final_sum_sq / placed) : 0.0;
  std::printf(
      "%s, loop closing %s: OK %d of %zu frames, ATE %.4f m (from frame %zu: %.4f m), last frame %.4f m, "
      "largest OK error %.4f m, at frame %zu %.4f m; in the final map: ATE %.4f m, at frame %zu %.4f m, "
      "%d OK frames not placed; keyframes checked %lld, consistent candidates %lld, loops closed %lld\n",
      name, loop_closing ? "on" : "off", out.ok_frames, rendered.frames.size(), out.ate_m, late_from,
      out.late_ate_m, out.return_error_m, out.max_ok_error_m, at_frame, out.error_at_frame_m, out.final_ate_m,
      at_frame, out.final_error_at_frame_m, out.final_left_out,
      static_cast<long long>(out.loops.keyframes_checked),
      static_cast<long long>(out.loops.consistent_candidates),
      static_cast<long long>(out.loops.loops_closed));
}

TEST(LoopClosing, ChecksEveryKeyFrameOfABackAndForthRunAndMakesItNoWorse) {
  const auto vocabulary = train_on_static(kWidth, kHeight);
  ASSERT_NE(vocabulary, nullptr);
  Rendered rendered;
  ASSERT_NO_FATAL_FAILURE(render(rendered));
  BackAndForthRun off;
  ASSERT_NO_FATAL_FAILURE(run_back_and_forth(rendered, vocabulary, false, off));
  BackAndForthRun on;
  ASSERT_NO_FATAL_FAILURE(run_back_and_forth(rendered, vocabulary, true, on));
  EXPECT_EQ(off.loops.keyframes_checked, 0);
  EXPECT_GE(on.loops.keyframes_checked, 10) << "the loop closer saw too few keyframes";
  EXPECT_GE(on.ok_frames, off.ok_frames);
  EXPECT_LE(on.ate_m, off.ate_m + 0.001);
  EXPECT_LT(on.max_ok_error_m, 0.05);
  ASSERT_GE(on.return_error_m, 0.0) << "not OK back at the start";
  EXPECT_LE(on.return_error_m, off.return_error_m + 0.001);
  if (on.loops.loops_closed == 0) {
    // Nothing closed: the run must be the same, pose for pose.
    ASSERT_EQ(on.poses.size(), off.poses.size());
    for (std::size_t i = 0; i < on.poses.size(); ++i) {
      EXPECT_EQ(on.poses[i].T_world_cam.matrix(), off.poses[i].T_world_cam.matrix()) << "frame " << i;
    }
  }
}

// Scenario loop, seed 2: once round a block and on past the start (540
// frames). Tracking does not bridge the revisit (the far side saw open
// ground, not the start's structures), so the map comes back to the start
// drifted, and the closer closes the loop there. From frame 440 (after the
// return) the error is lower with loop closing, and the closer accepts no
// false loop (a false one would move the map by metres). Re-expressed in
// the final map (SlamSystem::poses_in_final_map), the frame where the start
// is passed again (420) is within the 0.02 m, and the whole run is
// closer to the truth than the poses published live. Measured with
// `sitepose run` on seeds 1-3 in docs/placerec/README.md.
TEST(LoopClosing, ClosesTheLoopRoundABlockAndLowersTheErrorAfterIt) {
  const auto vocabulary = train_on_static(kWidth, kHeight);
  ASSERT_NE(vocabulary, nullptr);
  Rendered rendered;
  ASSERT_NO_FATAL_FAILURE(render(rendered, "loop", 540, 2));
  constexpr std::size_t kAfterTheReturn = 440;
  constexpr std::size_t kBackAtTheStart = 420;
  BackAndForthRun off;
  ASSERT_NO_FATAL_FAILURE(
      run_back_and_forth(rendered, vocabulary, false, off, "loop seed 2", kAfterTheReturn, kBackAtTheStart));
  BackAndForthRun on;
  ASSERT_NO_FATAL_FAILURE(
      run_back_and_forth(rendered, vocabulary, true, on, "loop seed 2", kAfterTheReturn, kBackAtTheStart));
  EXPECT_GE(on.loops.loops_closed, 1) << "no loop closed";
  EXPECT_GE(on.ok_frames, off.ok_frames - 5);
  EXPECT_LT(on.late_ate_m, off.late_ate_m);
  EXPECT_LE(on.ate_m, off.ate_m + 0.002);
  EXPECT_LT(on.max_ok_error_m, off.max_ok_error_m + 0.02);
  // The final map: the loop's correction reaches the frames before it.
  EXPECT_EQ(on.final_left_out, 0);
  ASSERT_GE(on.final_error_at_frame_m, 0.0) << "frame " << kBackAtTheStart << " not OK";
  EXPECT_LE(on.final_error_at_frame_m, 0.02);
  EXPECT_LT(on.final_ate_m, on.ate_m);
  EXPECT_GT(off.final_error_at_frame_m, 0.02) << "without the loop the start is reached drifted";
}

}  // namespace
}  // namespace sitepose::experiments
