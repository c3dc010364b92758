// The debug record reads back what was written, and the frame range parser.

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "sitepose/testing/files.hpp"
#include "sitepose/views/debug_record.hpp"
#include "sitepose/views/frame_view.hpp"
#include "sitepose/views/view_writer.hpp"

namespace sitepose::views {
namespace {

slam::FrameReport sample_report(std::int64_t seq) {
  slam::FrameReport r;
  r.pose.seq = seq;
  r.pose.t_ns = 1'000'000'000 + seq * 100'000'000;
  r.pose.state = seq == 0 ? TrackingState::kRecovering : TrackingState::kOk;
  r.pose.state_reason = seq == 0 ? "initialising map" : "";
  r.pose.T_world_cam = SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * seq, Eigen::Vector3d::UnitY())),
                           Eigen::Vector3d(0.5 * seq, -0.25, 2.0));
  r.pose.counters.features_extracted = 3;
  r.pose.counters.features_used_pass1 = 2;
  r.pose.counters.features_used = 3;
  r.mar = 0.375;
  r.masked_ratio = 0.25;
  r.pixel_mask_used = true;
  r.pass2_rejected = seq == 1;
  r.timings.extract_left_ms = 4.5;
  r.timings.total_ms = 20.25;
  r.trace.keypoints = {
      {10.5F, 20.5F, 0, slam::KeypointTrace::kUsablePass1 | slam::KeypointTrace::kInlierPass1},
      {100.0F, 50.0F, 7, slam::KeypointTrace::kUsablePass2 | slam::KeypointTrace::kInlierPass2},
      {120.0F, 60.0F, 7, 0}};
  r.trace.boxes = {{7, "roller", 1.0, cv::Rect(90, 40, 50, 30)}};
  r.trace.pass2_ran = true;
  r.trace.pass2_used = true;
  r.trace.keyframes_in_map = 4;
  r.trace.points_in_map = 812;
  r.trace.keyframes_created = 5;
  dynamic::ClassifiedObject object;
  object.verdict.instance = 7;
  object.verdict.class_name = "roller";
  object.verdict.raw = dynamic::MotionState::kStatic;
  object.verdict.state = dynamic::MotionState::kMoving;
  object.verdict.score = 12.5;
  object.verdict.map_statistic = 3.25;
  object.verdict.points = 17;
  r.objects.push_back(object);
  return r;
}

TEST(DebugRecord, ReadsBackWhatWasWritten) {
  testing::TempDir dir;
  RunInfo info{"0.1.0", "abc123", "/data/seq", "", "full", "labels", 320, 180, 10.0};
  auto writer = DebugRecordWriter::open(dir / "run", info, "dynamic:\n  mode: full\n");
  ASSERT_TRUE(writer) << writer.error().message;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE((*writer)->write(sample_report(i)));
  ASSERT_TRUE((*writer)->close());
  EXPECT_GT((*writer)->write_ms(), 0.0);

  auto record = read_debug_record(dir / "run");
  ASSERT_TRUE(record) << record.error().message;
  EXPECT_EQ(record->info.sequence, "/data/seq");
  EXPECT_EQ(record->info.detector, "labels");
  EXPECT_EQ(record->info.width, 320);
  EXPECT_DOUBLE_EQ(record->info.fps, 10.0);
  EXPECT_EQ(record->config_yaml, "dynamic:\n  mode: full\n");
  ASSERT_EQ(record->frames.size(), 3U);
  const FrameRecord& f = record->frames[1];
  EXPECT_EQ(f.seq, 1);
  EXPECT_EQ(f.t_ns, 1'100'000'000);
  EXPECT_EQ(f.state, TrackingState::kOk);
  EXPECT_EQ(record->frames[0].state_reason, "initialising map");
  EXPECT_TRUE(f.pass2_rejected);
  EXPECT_TRUE(f.pixel_mask_used);
  EXPECT_DOUBLE_EQ(f.mar, 0.375);
  EXPECT_DOUBLE_EQ(f.timings.total_ms, 20.25);
  EXPECT_EQ(f.counters.features_used_pass1, 2);
  EXPECT_NEAR((f.T_world_cam.translation() - sample_report(1).pose.T_world_cam.translation()).norm(), 0.0,
              1e-6);
  EXPECT_NEAR(f.T_world_cam.rotation().angularDistance(sample_report(1).pose.T_world_cam.rotation()), 0.0,
              1e-6);
  ASSERT_EQ(f.trace.keypoints.size(), 3U);
  EXPECT_FLOAT_EQ(f.trace.keypoints[0].u_px, 10.5F);
  EXPECT_EQ(f.trace.keypoints[1].instance, 7);
  EXPECT_EQ(f.trace.keypoints[1].flags,
            slam::KeypointTrace::kUsablePass2 | slam::KeypointTrace::kInlierPass2);
  ASSERT_EQ(f.trace.boxes.size(), 1U);
  EXPECT_EQ(f.trace.boxes[0].box, cv::Rect(90, 40, 50, 30));
  EXPECT_EQ(f.trace.boxes[0].class_name, "roller");
  EXPECT_EQ(f.trace.points_in_map, 812U);
  EXPECT_EQ(f.trace.keyframes_created, 5);
  ASSERT_EQ(f.objects.size(), 1U);
  EXPECT_EQ(f.objects[0].state, dynamic::MotionState::kMoving);
  EXPECT_EQ(f.objects[0].raw, dynamic::MotionState::kStatic);
  EXPECT_DOUBLE_EQ(f.objects[0].score, 12.5);
  ASSERT_TRUE(f.objects[0].map_statistic.has_value());
  EXPECT_DOUBLE_EQ(*f.objects[0].map_statistic, 3.25);
  EXPECT_EQ(f.objects[0].points, 17);
}

TEST(DebugRecord, MissingOrBrokenRecordIsAnErrorNamingTheFile) {
  testing::TempDir dir;
  auto missing = read_debug_record(dir / "none");
  ASSERT_FALSE(missing);
  dir.write("run/run.txt", "mode full\n");
  dir.write("run/frames.txt", "# sitepose debug record 1\nF 0 1 0 x\n");
  auto broken = read_debug_record(dir / "run");
  ASSERT_FALSE(broken);
  EXPECT_NE(broken.error().message.find("frames.txt:2"), std::string::npos) << broken.error().message;
}

TEST(FrameRange, ParsesAandBAndRejectsTheRest) {
  auto both = parse_frame_range("3:9");
  ASSERT_TRUE(both);
  EXPECT_EQ(both->first, 3U);
  EXPECT_EQ(both->end, 9U);
  auto open_end = parse_frame_range("5:");
  ASSERT_TRUE(open_end);
  EXPECT_EQ(open_end->end, 0U);
  for (const char* bad : {"5", "9:3", "a:b", "-1:4", "3:3"}) EXPECT_FALSE(parse_frame_range(bad)) << bad;
}

TEST(FrameView, DrawsTheFrameWithATopViewBesideIt) {
  DebugRecord record;
  for (int i = 0; i < 3; ++i) {
    const slam::FrameReport r = sample_report(i);
    FrameRecord f;
    f.seq = r.pose.seq;
    f.state = r.pose.state;
    f.T_world_cam = r.pose.T_world_cam;
    f.trace = r.trace;
    f.pixel_mask_used = true;
    f.objects.push_back(r.objects[0].verdict);
    record.frames.push_back(f);
  }
  std::vector<std::optional<SE3>> gt(3, SE3());
  const TopViewTracks tracks = top_view_tracks(record, gt);
  ASSERT_EQ(tracks.estimate.size(), 3U);
  ASSERT_TRUE(tracks.estimate[2]);
  // Relative to frame 0: frame 2 is 1 m to the right.
  EXPECT_NEAR(tracks.estimate[2]->x, 1.0 * std::cos(0.0), 0.2);
  const cv::Mat left(180, 320, CV_8UC1, cv::Scalar(90));
  cv::Mat mask(180, 320, CV_16UC1, cv::Scalar(0));
  mask(cv::Rect(90, 40, 50, 30)).setTo(7);
  const cv::Mat image = render_frame(left, mask, record, 2, tracks);
  EXPECT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.cols, 320 + 180);
  EXPECT_EQ(image.rows, 180);
  // The moving object's pixel mask is tinted (magenta: blue and red above green).
  const cv::Vec3b tinted = image.at<cv::Vec3b>(55, 115);
  EXPECT_GT(tinted[0], tinted[1] + 40);
  EXPECT_GT(tinted[2], tinted[1] + 40);
}

}  // namespace
}  // namespace sitepose::views
