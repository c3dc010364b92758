#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "sitepose/slam/run_recorder.hpp"
#include "sitepose/slam/slam_system.hpp"
#include "sitepose/testing/cameras.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::slam {
namespace {

// A 64 x 48 camera: enough for SlamSystem to run where a test looks at the
// dynamic layer.
StereoCamera tiny_camera() { return testing::centred_camera(64, 48, 100.0, 0.5); }

// One textureless frame (the map never initialises) with `boxes` through a
// fresh SlamSystem in `mode`.
Expected<FrameReport> process_blank_frame(config::MaskingMode mode, std::vector<dynamic::ObjectBox> boxes) {
  config::SiteposeConfig config;
  config.dynamic.mode = mode;
  SITEPOSE_TRY(std::unique_ptr<SlamSystem> system, SlamSystem::create(tiny_camera(), config));
  StereoFrame frame;
  frame.left = cv::Mat(48, 64, CV_8UC1, cv::Scalar(100));
  frame.right = frame.left.clone();
  dynamic::FrameObjects objects;
  objects.boxes = std::move(boxes);
  return system->process(frame, objects);
}

TEST(RunRecorder, WritesStatesCsvOfDynamicReports) {
  FrameReport report;
  report.dynamic_layer = true;
  report.pose.seq = 7;
  report.mar = 0.55;
  report.pixel_mask_used = true;
  dynamic::ClassifiedObject o;
  o.verdict.instance = 12;
  o.verdict.class_name = "truck";
  o.verdict.state = dynamic::MotionState::kStatic;
  o.verdict.score = 1.25;
  o.verdict.points = 40;
  report.objects.push_back(o);
  RunRecorder recorder;
  recorder.add(report);
  EXPECT_EQ(recorder.pixel_mask_calls(), 1);
  ASSERT_EQ(recorder.masked_area_ratios().size(), 1u);
  const testing::TempDir dir;
  const std::string path = dir / "states_test.csv";
  ASSERT_TRUE(recorder.write_states_csv(path));
  EXPECT_EQ(testing::read_text(path),
            "frame,instance,class,state,score,points,reason\n7,12,truck,static,1.2500,40,\n");
}

// --final-out writes the frames --out writes (not LOST), each at its final
// pose; a frame without one is left out and counted.
TEST(RunRecorder, FinalTrajectoryHasTheFramesOfTheTrajectoryAtTheirFinalPoses) {
  RunRecorder recorder;
  const TrackingState states[] = {TrackingState::kOk, TrackingState::kLost, TrackingState::kRecovering,
                                  TrackingState::kOk};
  for (int i = 0; i < 4; ++i) {
    FrameReport report;
    report.pose.t_ns = (i + 1) * 1'000'000'000LL;
    report.pose.state = states[i];
    report.pose.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i, 0, 0));
    recorder.add(report);
  }
  const SE3 moved(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 5, 0));
  const std::vector<std::optional<SE3>> final_poses{moved, std::nullopt, moved, std::nullopt};
  const testing::TempDir dir;
  const auto counts =
      recorder.write_final_trajectory(dir / "final.txt", io::TrajectoryFormat::kTum, final_poses);
  ASSERT_TRUE(counts) << counts.error().message;
  EXPECT_EQ(counts->poses, 2);
  EXPECT_EQ(counts->left_out, 1);  // frame 3; frame 1 is LOST, in neither file
  ASSERT_TRUE(recorder.write_trajectory(dir / "live.txt", io::TrajectoryFormat::kTum));
  const std::string header = "# t x y z qx qy qz qw (T_world_cam of the left camera)\n";
  EXPECT_EQ(testing::read_text(dir / "final.txt"),
            header + "1.000000000 0 5 0 0 0 0 1\n3.000000000 0 5 0 0 0 0 1\n");
  EXPECT_EQ(testing::read_text(dir / "live.txt"),
            header + "1.000000000 0 0 0 0 0 0 1\n3.000000000 2 0 0 0 0 0 1\n4.000000000 3 0 0 0 0 0 1\n");
  // One final pose per frame, or nothing is written.
  EXPECT_FALSE(recorder.write_final_trajectory(dir / "bad.txt", io::TrajectoryFormat::kTum, {moved}));
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.txt"));
}

TEST(SlamSystem, PixelModeWithoutSegmenterIsUnsupported) {
  const auto report =
      process_blank_frame(config::MaskingMode::kPixel, {{1, "truck", 1.0, cv::Rect(0, 0, 10, 10)}});
  ASSERT_FALSE(report);
  EXPECT_EQ(report.error().code, ErrorCode::kUnsupported);
}

// Mode none masks nothing but reports mar like the masking modes: the
// dynamic-class boxes only, clipped to the image.
TEST(SlamSystem, ModeNoneReportsTheMarOfDynamicClassBoxes) {
  const auto report = process_blank_frame(
      config::MaskingMode::kNone, {{1, "truck", 1.0, cv::Rect(-8, 0, 24, 12)},    // 16 x 12 inside
                                   {2, "cone", 1.0, cv::Rect(30, 30, 10, 10)}});  // not a dynamic class
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_TRUE(report->dynamic_layer);
  EXPECT_DOUBLE_EQ(report->mar, 16.0 * 12.0 / (64.0 * 48.0));
  EXPECT_DOUBLE_EQ(report->pose.counters.masked_area_ratio, report->mar);
}

TEST(SlamSystem, RejectsNonPositiveFps) {
  SlamOptions options;
  options.fps = 0.0;
  auto system = SlamSystem::create(tiny_camera(), config::SiteposeConfig{}, options);
  ASSERT_FALSE(system);
  EXPECT_EQ(system.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace sitepose::slam
