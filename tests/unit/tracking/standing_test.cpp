#include "sitepose/tracking/standing.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace sitepose::tracking {
namespace {

constexpr std::int64_t kFrameNs = 166'666'667;  // 6 frames/s, as the scenarios

// T_cam_world of a camera at x_m along the world x axis.
SE3 camera_at(double x_m) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-x_m, 0.0, 0.0)); }

TEST(StandingDetector, AnchorsAfterHalfASecondStill) {
  StandingDetector detector;
  // 2 mm of jitter per frame stays within the still radius.
  for (int i = 0; i < 3; ++i) {
    detector.update(i * kFrameNs, camera_at(0.002 * (i % 2)), 300);
    EXPECT_FALSE(detector.anchor().has_value()) << "frame " << i;
  }
  detector.update(3 * kFrameNs, camera_at(0.002), 300);
  ASSERT_TRUE(detector.anchor().has_value());
  EXPECT_NEAR(pose_distance(*detector.anchor(), camera_at(0.002)).translation_m, 0.0, 1e-12);
}

TEST(StandingDetector, NeverAnchorsWhileDriving) {
  StandingDetector detector;
  // 0.1 m/s at 6 frames/s: 17 mm a frame, more than the still radius.
  for (int i = 0; i < 30; ++i) {
    detector.update(i * kFrameNs, camera_at(0.1 * i / 6.0), 300);
    EXPECT_FALSE(detector.anchor().has_value()) << "frame " << i;
  }
}

TEST(StandingDetector, KeepsItsAnchorUntilForgotten) {
  StandingDetector detector;
  for (int i = 0; i < 4; ++i) detector.update(i * kFrameNs, camera_at(0.0), 300);
  ASSERT_TRUE(detector.anchor().has_value());
  // A pose far away does not move the anchor: only a confirmed drive-off does.
  detector.update(4 * kFrameNs, camera_at(1.0), 300);
  ASSERT_TRUE(detector.anchor().has_value());
  EXPECT_NEAR(pose_distance(*detector.anchor(), camera_at(0.0)).translation_m, 0.0, 1e-12);
  detector.forget();
  EXPECT_FALSE(detector.anchor().has_value());
  // Standing again elsewhere: a new window, a new anchor.
  for (int i = 5; i < 9; ++i) detector.update(i * kFrameNs, camera_at(2.0), 300);
  ASSERT_TRUE(detector.anchor().has_value());
  EXPECT_NEAR(pose_distance(*detector.anchor(), camera_at(2.0)).translation_m, 0.0, 1e-12);
}

TEST(StandingDetector, StillMeansWithinRadiusAndAngle) {
  EXPECT_TRUE(StandingDetector::still(camera_at(0.0), camera_at(0.009)));
  EXPECT_FALSE(StandingDetector::still(camera_at(0.0), camera_at(0.011)));
  const SE3 turned(Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())),
                   Eigen::Vector3d::Zero());
  EXPECT_FALSE(StandingDetector::still(camera_at(0.0), turned));
  EXPECT_NEAR(pose_distance(camera_at(0.0), turned).rotation_rad, 0.01, 1e-9);
}

// A frame whose estimate left the still radius: the re-estimate from the
// anchor found `inliers`, `outside` of them outside the moved pose's gate.
TwoMotions two_motions(double moved_m, int inliers, int outside, double reestimate_m) {
  TwoMotions m;
  m.moved_m = moved_m;
  m.reestimate_valid = inliers >= 12;
  m.reestimate_inliers = inliers;
  m.reestimate_m = reestimate_m;
  m.outside_moved_gate = outside;
  m.reestimate_precise = inliers >= 30;
  m.standing_inliers = 300;
  return m;
}

TEST(StandingTwoMotions, ADriveOffThatKeepsTheViewIsMovedAtOnce) {
  EXPECT_EQ(judge_two_motions(two_motions(0.02, 280, 0, 0.02)), StandingVerdict::kMoved);
  // Beyond the left radius: the re-estimate kept half the standing view.
  EXPECT_EQ(judge_two_motions(two_motions(0.09, 200, 30, 0.09)), StandingVerdict::kMoved);
}

TEST(StandingTwoMotions, AgreementOnAFewMatchesFarOffIsNotEnough) {
  // 41 matches (a truck's repeated texture) agree on a pose 7-9 cm off.
  EXPECT_EQ(judge_two_motions(two_motions(0.066, 41, 0, 0.094)), StandingVerdict::kUnsure);
  // Within the left radius either hypothesis is right to within it.
  EXPECT_EQ(judge_two_motions(two_motions(0.03, 41, 0, 0.03)), StandingVerdict::kMoved);
}

TEST(StandingTwoMotions, ASteadyDepartureIsMovedAfterHalfASecond) {
  TwoMotions m = two_motions(0.09, 85, 1, 0.087);
  m.departing_s = 0.33;
  EXPECT_EQ(judge_two_motions(m), StandingVerdict::kUnsure);
  m.departing_s = 0.5;
  EXPECT_EQ(judge_two_motions(m), StandingVerdict::kMoved);
  m.reestimate_precise = false;
  EXPECT_EQ(judge_two_motions(m), StandingVerdict::kUnsure);
}

TEST(StandingTwoMotions, BackgroundThatFitsOnlyTheStandingPoseHoldsIt) {
  EXPECT_EQ(judge_two_motions(two_motions(0.4, 60, 55, 0.004)), StandingVerdict::kHeld);
  // ... but not when the re-estimate itself left the anchor.
  EXPECT_EQ(judge_two_motions(two_motions(0.4, 60, 55, 0.2)), StandingVerdict::kUnsure);
}

TEST(StandingTwoMotions, InDoubtUnsure) {
  EXPECT_EQ(judge_two_motions(two_motions(0.4, 100, 35, 0.004)),
            StandingVerdict::kUnsure);  // between the shares
  EXPECT_EQ(judge_two_motions(two_motions(0.4, 5, 0, 0.0)),
            StandingVerdict::kUnsure);  // too few from the anchor
}

TEST(StandingDetector, DepartureCountsOnlyWhileThePoseLeavesFurther) {
  StandingDetector detector;
  for (int i = 0; i < 4; ++i) detector.update(i * kFrameNs, camera_at(0.0), 300);
  ASSERT_TRUE(detector.anchor().has_value());
  detector.note_departure(4 * kFrameNs, two_motions(0.02, 100, 0, 0.02));
  detector.note_departure(5 * kFrameNs, two_motions(0.04, 100, 0, 0.04));
  EXPECT_NEAR(detector.departing_s(6 * kFrameNs, 0.07), 2 * kFrameNs * 1e-9, 1e-9);
  EXPECT_EQ(detector.departing_s(6 * kFrameNs, 0.03), 0.0);  // back towards the anchor
  // A frame that jumps back starts over; one that does not agree ends it.
  detector.note_departure(6 * kFrameNs, two_motions(0.01, 100, 0, 0.01));
  EXPECT_NEAR(detector.departing_s(7 * kFrameNs, 0.05), kFrameNs * 1e-9, 1e-9);
  detector.note_departure(7 * kFrameNs, two_motions(0.05, 100, 60, 0.01));
  EXPECT_EQ(detector.departing_s(8 * kFrameNs, 0.08), 0.0);
  detector.note_still();
  EXPECT_EQ(detector.departing_s(8 * kFrameNs, 0.08), 0.0);
}

}  // namespace
}  // namespace sitepose::tracking
