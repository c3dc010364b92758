// Issue 19: relocalisation anywhere in the map through the keyframe
// database (placerec). A roller drives 16 m down its lane (scenario
// backforth), then is "kidnapped": the frames fed next are those from
// where it passed 13-14 m back, with times running on. The reference
// keyframe and its covisible keyframes (what ORB-SLAM2 tracks against)
// do not see that place; the database must name it. The vocabulary is
// trained at test time on another scenario (static), so it has never
// seen these images. Every OK pose is scored against the ground truth.

#include <gtest/gtest.h>

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

struct KidnapRun {
  int drive_frames = 0;        // frames of the drive before the kidnap
  int first_kidnapped = 0;     // source index of the first frame after it
  double jump_m = 0.0;         // ground-truth distance of the jump
  double local_set_gap_m = 0;  // nearest centre of the reference KF and its covisible KFs to the new place
  int frames_to_relocalise = -1;
  int ok_after = 0;
  int kidnapped_frames = 0;
  int ok_frames_off = 0;  // OK poses more than 0.05 m off, after the kidnap
  double max_ok_error_m = 0.0;
  double max_ok_error_drive_m = 0.0;  // before it (odometry drift over the drive)
  std::size_t database_keyframes = 0;
  long database_queries = 0;
};

void run_kidnap(const std::shared_ptr<const placerec::Vocabulary>& vocabulary, KidnapRun& out,
                const config::TrackingConfig& tracking = {}) {
  constexpr int kDrive = 114;  // 2 s standing, then 16 m at up to 1 m/s
  constexpr int kKidnapped = 24;
  auto source = open_simulated(kScenarioDir + "/backforth.yaml", kDrive + 1, std::nullopt, kWidth, kHeight);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  config.tracking = tracking;
  slam::SlamOptions options;
  options.fps = (*source)->fps();
  options.vocabulary = vocabulary;
  auto system = slam::SlamSystem::create((*source)->camera(), config, options);
  ASSERT_TRUE(system.has_value()) << system.error().message;
  std::vector<SE3> truth;  // the first frame's, then per frame of the drive: T_first_cam
  std::int64_t t_ns = 0;
  const auto track = [&](int index, std::int64_t seq) -> std::optional<PoseEstimate> {
    auto frame = (*source)->read(index);
    EXPECT_TRUE(frame.has_value());
    if (!frame || !frame->T_world_cam_gt) return std::nullopt;
    if (truth.empty()) truth.push_back(*frame->T_world_cam_gt);
    const SE3 T_first_cam = truth[0].inverse() * *frame->T_world_cam_gt;
    if (seq == index) truth.push_back(T_first_cam);
    frame->frame.seq = seq;
    t_ns = seq == 0 ? frame->frame.t_ns() : t_ns + static_cast<std::int64_t>(1e9 / options.fps);
    frame->frame.t_left_ns = frame->frame.t_right_ns = t_ns;
    auto report = (*system)->process(frame->frame);
    EXPECT_TRUE(report.has_value());
    if (!report) return std::nullopt;
    const PoseEstimate& pose = report->pose;
    if (pose.state == TrackingState::kOk) {
      // World = the first left camera in both.
      const double error_m = (pose.T_world_cam.translation() - T_first_cam.translation()).norm();
      if (seq == index) {
        out.max_ok_error_drive_m = std::max(out.max_ok_error_drive_m, error_m);
      } else {
        out.max_ok_error_m = std::max(out.max_ok_error_m, error_m);
        if (error_m > 0.05) ++out.ok_frames_off;
      }
    }
    return pose;
  };
  for (int i = 0; i < kDrive; ++i) ASSERT_TRUE(track(i, i).has_value());
  out.drive_frames = kDrive;
  // The kidnapped place: where the roller was ~13.5 m before the end.
  const auto position = [&](int i) { return truth[static_cast<std::size_t>(i) + 1].translation(); };
  const Eigen::Vector3d end = position(kDrive - 1);
  int first = 0;
  while (first < kDrive && (position(first) - end).norm() > 13.5) ++first;
  out.first_kidnapped = first;
  out.jump_m = (position(first) - end).norm();
  // What local candidates could offer: the last keyframe and its covisible ones.
  const map::MapData map = (*system)->copy_map();
  const Eigen::Vector3d place = position(first);
  out.local_set_gap_m = 1e9;
  std::vector<map::KeyFrameId> local = map.best_covisible(map.last_keyframe(), 5);
  local.push_back(map.last_keyframe());
  for (map::KeyFrameId id : local) {
    if (const map::KeyFrame* kf = map.keyframe(id); kf != nullptr)
      out.local_set_gap_m = std::min(out.local_set_gap_m, (kf->camera_center() - place).norm());
  }
  if (const placerec::KeyFrameDatabase* db = (*system)->keyframe_database(); db != nullptr)
    out.database_keyframes = db->size();
  for (int j = 0; j < kKidnapped; ++j) {
    const auto pose = track(first + j, kDrive + j);
    ASSERT_TRUE(pose.has_value());
    ++out.kidnapped_frames;
    if (out.frames_to_relocalise < 0 && pose->state != TrackingState::kLost) out.frames_to_relocalise = j;
    if (pose->state == TrackingState::kOk) ++out.ok_after;
  }
  out.database_queries = (*system)->place_queries().queries;
  std::printf(
      "kidnap (%s): drove %d frames, jumped %.1f m back to frame %d; nearest local-set keyframe %.1f m "
      "from there; database %zu keyframes, %ld queries; relocalised after %d frames, OK on %d of %d frames "
      "after; "
      "largest OK error %.4f m (before the kidnap %.4f m), OK poses > 0.05 m off after it: %d\n",
      vocabulary ? vocabulary->id().c_str() : "exact vote", out.drive_frames, out.jump_m, out.first_kidnapped,
      out.local_set_gap_m, out.database_keyframes, out.database_queries, out.frames_to_relocalise,
      out.ok_after, out.kidnapped_frames, out.max_ok_error_m, out.max_ok_error_drive_m, out.ok_frames_off);
}

void expect_relocalised_right(const KidnapRun& run) {
  EXPECT_GT(run.jump_m, 12.0);
  EXPECT_GE(run.frames_to_relocalise, 0) << "never relocalised";
  EXPECT_LT(run.frames_to_relocalise, 5);
  EXPECT_GE(run.ok_after, run.kidnapped_frames / 2);
  EXPECT_EQ(run.ok_frames_off, 0) << "largest error of an OK pose: " << run.max_ok_error_m << " m";
}

TEST(Kidnap, RelocalisesThroughTheKeyFrameDatabase) {
  const auto vocabulary = train_on_static(kWidth, kHeight);
  ASSERT_NE(vocabulary, nullptr);
  KidnapRun run;
  ASSERT_NO_FATAL_FAILURE(run_kidnap(vocabulary, run));
  expect_relocalised_right(run);
  EXPECT_GT(run.database_keyframes, 3U);
  EXPECT_GE(run.database_queries, 1) << "the candidates must come from the database";
}

// The default without a vocabulary: the exact nearest-point vote over the
// whole map finds the place too (the same safety gates decide OK).
TEST(Kidnap, RelocalisesThroughTheExactVoteWithoutAVocabulary) {
  KidnapRun run;
  ASSERT_NO_FATAL_FAILURE(run_kidnap(nullptr, run));
  expect_relocalised_right(run);
  EXPECT_EQ(run.database_queries, 0);
}

// Keypoints kept at the last frame's predicted matches
// (tracking.keep_tracked_corners) must not let the old place's points hold
// the camera there: after the jump they gave the motion-model search 17
// chance matches, and a keyframe from that frame made a map at the old
// place that the next 23 frames tracked OK, 13.7 m off.
TEST(Kidnap, KeptCornersDoNotHoldTheCameraAtItsOldPlace) {
  config::TrackingConfig tracking;
  tracking.keep_tracked_corners = true;
  tracking.keyframe_travel_depth_share = 0.05;
  KidnapRun run;
  ASSERT_NO_FATAL_FAILURE(run_kidnap(nullptr, run, tracking));
  expect_relocalised_right(run);
}

}  // namespace
}  // namespace sitepose::experiments
