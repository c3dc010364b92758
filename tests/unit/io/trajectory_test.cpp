#include "sitepose/io/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "sitepose/testing/files.hpp"

namespace sitepose::io {
namespace {

using testing::TempDir;

SE3 test_pose(int i) {
  Vector6d xi;
  xi << 0.3 * i, -1.25 + 0.1 * i, 12.5 * i, 0.05 * i, -0.3 + 0.02 * i, 0.7 - 0.1 * i;
  return SE3::exp(xi);
}

// tol is relative for translations: %.9g keeps 9 significant digits.
void expect_pose_near(const SE3& a, const SE3& b, double tol) {
  EXPECT_LT((a.translation() - b.translation()).norm(), tol * (1.0 + b.translation().norm()));
  EXPECT_LT(rotation_angle_rad(a.rotation().inverse() * b.rotation()), tol);
}

TEST(TumTrajectory, WriteReadRoundTrip) {
  TempDir dir;
  Trajectory trajectory;
  for (int i = 0; i < 20; ++i) trajectory.push_back({1700000000.0 + 0.1 * i + 1e-9 * i, test_pose(i)});
  const std::string path = dir / "traj.tum";
  ASSERT_TRUE(write_tum_trajectory(path, trajectory));
  auto read = read_tum_trajectory(path);
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), trajectory.size());
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    // %.9f keeps nanoseconds of an epoch time; %.9g keeps ~1e-9 relative.
    EXPECT_NEAR((*read)[i].t_s, trajectory[i].t_s, 2e-9);
    expect_pose_near((*read)[i].T_world_cam, trajectory[i].T_world_cam, 1e-8);
  }
}

TEST(TumTrajectory, CommentsAndBlankLinesSkipped) {
  TempDir dir;
  const std::string path = dir.write("t.tum",
                                     "# header\n\n1.0 1 2 3 0 0 0 1\n   # indented comment\n"
                                     "2.5 4 5 6 0 0 0.7071067811865476 0.7071067811865476\n\n");
  auto read = read_tum_trajectory(path);
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), 2u);
  EXPECT_DOUBLE_EQ((*read)[1].t_s, 2.5);
  EXPECT_NEAR((*read)[1].T_world_cam.translation().y(), 5.0, 1e-12);
  // qz = qw = sqrt(1/2): 90 degrees about z.
  EXPECT_NEAR(rotation_angle_rad((*read)[1].T_world_cam.rotation()), M_PI / 2, 1e-9);
  EXPECT_NEAR((*read)[1].T_world_cam.rotation().z(), std::sqrt(0.5), 1e-9);
}

TEST(TumTrajectory, MalformedLineNamesFileAndLine) {
  TempDir dir;
  const std::string path = dir.write("bad.tum", "# c\n1.0 1 2 3 0 0 0 1\n2.0 1 2 3 0 0 1\n");
  auto read = read_tum_trajectory(path);
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_NE(read.error().message.find("bad.tum:3: expected 8 numbers, got 7"), std::string::npos)
      << read.error().message;
}

TEST(TumTrajectory, NonNumberAndNonFiniteRejected) {
  TempDir dir;
  auto word = read_tum_trajectory(dir.write("a.tum", "1.0 1 2 x 0 0 0 1\n"));
  ASSERT_FALSE(word);
  EXPECT_NE(word.error().message.find("a.tum:1: field 4 'x'"), std::string::npos) << word.error().message;
  auto nan = read_tum_trajectory(dir.write("b.tum", "1.0 1 2 nan 0 0 0 1\n"));
  ASSERT_FALSE(nan);
  EXPECT_NE(nan.error().message.find("b.tum:1: field 4 'nan' is not a finite number"), std::string::npos)
      << nan.error().message;
  auto inf = read_tum_trajectory(dir.write("c.tum", "inf 1 2 3 0 0 0 1\n"));
  ASSERT_FALSE(inf);
  EXPECT_NE(inf.error().message.find("c.tum:1: field 1"), std::string::npos);
}

TEST(TumTrajectory, NonUnitQuaternionAndUnorderedTimesRejected) {
  TempDir dir;
  auto zero_q = read_tum_trajectory(dir.write("q.tum", "1.0 1 2 3 0 0 0 0\n"));
  ASSERT_FALSE(zero_q);
  EXPECT_NE(zero_q.error().message.find("q.tum:1: expected a unit quaternion"), std::string::npos);
  auto order = read_tum_trajectory(dir.write("o.tum", "2.0 1 2 3 0 0 0 1\n1.0 1 2 3 0 0 0 1\n"));
  ASSERT_FALSE(order);
  EXPECT_NE(order.error().message.find("o.tum:2: expected a time after"), std::string::npos)
      << order.error().message;
}

TEST(TumTrajectory, MissingFileIsNotFound) {
  TempDir dir;
  auto read = read_tum_trajectory(dir / "nope.tum");
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().code, ErrorCode::kNotFound);
  EXPECT_NE(read.error().message.find("nope.tum"), std::string::npos);
}

TEST(TumTrajectory, WriteRefusesNonFinite) {
  TempDir dir;
  Trajectory trajectory{{std::nan(""), SE3()}};
  const Status s = write_tum_trajectory(dir / "x.tum", trajectory);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument);
}

TEST(TumTrajectory, WriteToMissingFolderFails) {
  TempDir dir;
  const Status s = write_tum_trajectory(dir / "no/such/dir/x.tum", {{0.0, SE3()}});
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, ErrorCode::kIoError);
  EXPECT_NE(s.error().message.find("no/such/dir/x.tum"), std::string::npos);
}

TEST(KittiPoses, WriteReadRoundTrip) {
  TempDir dir;
  std::vector<SE3> poses;
  for (int i = 0; i < 15; ++i) poses.push_back(test_pose(i));
  const std::string path = dir / "poses.txt";
  ASSERT_TRUE(write_kitti_poses(path, poses));
  auto read = read_kitti_poses(path);
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) expect_pose_near((*read)[i], poses[i], 1e-8);
}

TEST(KittiPoses, ReadsKittiStyleLine) {
  TempDir dir;
  // First line of KITTI sequence 00 ground truth, scientific notation.
  const std::string path =
      dir.write("00.txt",
                "1.000000e+00 9.043680e-12 2.326809e-11 5.551115e-17 9.043683e-12 1.000000e+00 "
                "2.392370e-10 3.330669e-16 2.326810e-11 2.392370e-10 9.999999e-01 -4.440892e-16\n"
                "9.999978e-01 5.272628e-04 -2.066935e-03 -4.690294e-02 -5.296506e-04 9.999992e-01 "
                "-1.154865e-03 -2.839928e-02 2.066324e-03 1.155958e-03 9.999971e-01 8.586941e-01\n\n");
  auto read = read_kitti_poses(path);
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), 2u);
  EXPECT_NEAR((*read)[1].translation().z(), 0.8586941, 1e-12);
}

TEST(KittiPoses, ShortLineNamed) {
  TempDir dir;
  std::string text;
  for (int i = 0; i < 16; ++i) text += "1 0 0 0 0 1 0 0 0 0 1 0\n";
  text += "1 0 0 0 0 1 0 0 0 0 1\n";
  auto read = read_kitti_poses(dir.write("poses.txt", text));
  ASSERT_FALSE(read);
  EXPECT_NE(read.error().message.find("poses.txt:17: expected 12 numbers, got 11"), std::string::npos)
      << read.error().message;
}

TEST(KittiPoses, BlankLineInsideAndNonRotationRejected) {
  TempDir dir;
  auto blank = read_kitti_poses(dir.write("a.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n\n1 0 0 0 0 1 0 0 0 0 1 0\n"));
  ASSERT_FALSE(blank);
  EXPECT_NE(blank.error().message.find("a.txt:2: expected 12 numbers, got 0"), std::string::npos)
      << blank.error().message;
  auto scaled = read_kitti_poses(dir.write("b.txt", "2 0 0 0 0 2 0 0 0 0 2 0\n"));
  ASSERT_FALSE(scaled);
  EXPECT_NE(scaled.error().message.find("b.txt:1: expected a rotation"), std::string::npos);
  auto mirrored = read_kitti_poses(dir.write("c.txt", "-1 0 0 0 0 1 0 0 0 0 1 0\n"));
  ASSERT_FALSE(mirrored);
  EXPECT_NE(mirrored.error().message.find("c.txt:1: expected a rotation"), std::string::npos);
}

TEST(Times, ReadsAndValidates) {
  TempDir dir;
  auto good = read_times(dir.write("times.txt", "0.000000e+00\n1.036400e-01\n2.072800e-01\n"));
  ASSERT_TRUE(good) << good.error().message;
  ASSERT_EQ(good->size(), 3u);
  EXPECT_DOUBLE_EQ((*good)[1], 0.10364);
  auto two = read_times(dir.write("t2.txt", "0.0\n0.1 0.2\n"));
  ASSERT_FALSE(two);
  EXPECT_NE(two.error().message.find("t2.txt:2: expected 1 number, got 2"), std::string::npos)
      << two.error().message;
  auto back = read_times(dir.write("t3.txt", "0.0\n0.1\n0.1\n"));
  ASSERT_FALSE(back);
  EXPECT_NE(back.error().message.find("t3.txt:3: expected a time after"), std::string::npos);
}

// issue 20: 1e11 s overflowed llround(t * 1e9) to -9.2e9 s, and times
// 1e-10 s apart became the same nanosecond: duplicate frame times.
TEST(Times, OutOfRangeAndSubNanosecondStepsRejected) {
  TempDir dir;
  auto epoch = read_times(dir.write("epoch.txt", "1700000000.0\n1700000000.000001\n4e9\n"));
  ASSERT_TRUE(epoch) << epoch.error().message;
  auto huge = read_times(dir.write("huge.txt", "0.0\n1e11\n"));
  ASSERT_FALSE(huge);
  EXPECT_EQ(huge.error().code, ErrorCode::kParseError);
  EXPECT_NE(huge.error().message.find("huge.txt:2: expected a time in 0..4e+09 s"), std::string::npos)
      << huge.error().message;
  auto negative = read_times(dir.write("neg.txt", "-0.5\n0.0\n"));
  ASSERT_FALSE(negative);
  EXPECT_NE(negative.error().message.find("neg.txt:1: expected a time in"), std::string::npos)
      << negative.error().message;
  auto close = read_times(dir.write("close.txt", "0.1\n0.1000000001\n"));
  ASSERT_FALSE(close);
  EXPECT_NE(close.error().message.find("close.txt:2: expected a time after 0.100000000 s"), std::string::npos)
      << close.error().message;
  EXPECT_NE(close.error().message.find("at least 1 ns"), std::string::npos);
}

TEST(KittiTrajectory, ZipsPosesAndTimes) {
  TempDir dir;
  std::vector<SE3> poses{test_pose(1), test_pose(2), test_pose(3)};
  ASSERT_TRUE(write_kitti_poses(dir / "poses.txt", poses));
  dir.write("times.txt", "0.0\n0.1\n0.2\n");
  auto traj = read_kitti_trajectory(dir / "poses.txt", dir / "times.txt");
  ASSERT_TRUE(traj) << traj.error().message;
  ASSERT_EQ(traj->size(), 3u);
  EXPECT_DOUBLE_EQ((*traj)[2].t_s, 0.2);
  expect_pose_near((*traj)[2].T_world_cam, poses[2], 1e-7);

  dir.write("times2.txt", "0.0\n0.1\n");
  auto mismatch = read_kitti_trajectory(dir / "poses.txt", dir / "times2.txt");
  ASSERT_FALSE(mismatch);
  EXPECT_NE(mismatch.error().message.find("has 3 poses"), std::string::npos);
  EXPECT_NE(mismatch.error().message.find("has 2 times"), std::string::npos);
}

TEST(TrajectoryFormat, NamesParseBackAndABadNameListsTheChoices) {
  for (TrajectoryFormat f : {TrajectoryFormat::kTum, TrajectoryFormat::kKitti, TrajectoryFormat::kEuroc}) {
    const auto parsed = parse_trajectory_format(to_string(f));
    EXPECT_TRUE(parsed.has_value() && *parsed == f) << to_string(f);
  }
  const auto bad = parse_trajectory_format("TUM");
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().message, "'TUM' is not one of tum, kitti, euroc");
}

}  // namespace
}  // namespace sitepose::io
