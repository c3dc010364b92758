#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sitepose/eval/metrics.hpp"

namespace sitepose::eval {
namespace {

SE3 pose(double yaw_deg, double x, double y) {
  return SE3(so3_exp(Eigen::Vector3d(0.0, 0.0, yaw_deg * std::numbers::pi / 180.0)),
             Eigen::Vector3d(x, y, 0.0));
}

// Hand-computed case. GT: identity rotation at x = 0, 1, 2 m (t = 0, 1, 2 s).
// Estimate: P0 = (I, 0), P1 = (I, (1.1, 0, 0)), P2 = (Rz(10 deg), (2.1, 0.2, 0)).
// E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j):
//   (0,1): Q rel = (I, (1,0,0)), P rel = (I, (1.1,0,0))          -> E = (I, (0.1,0,0)):
//          0.1 m, 0 deg
//   (1,2): P rel = (I, -(1.1,0,0)) (Rz10, (2.1,0.2,0)) = (Rz10, (1.0,0.2,0));
//          E = (I, (-1,0,0)) (Rz10, (1,0.2,0)) = (Rz10, (0,0.2,0))   -> 0.2 m, 10 deg
//   translation: rmse = sqrt((0.01 + 0.04) / 2) = 0.158113883, mean 0.15
//   rotation:    rmse = sqrt((0 + 100) / 2) = 7.0710678 deg,  mean 5 deg
//   over 2 s / 2 frames, (0,2): E = (I, (-2,0,0)) (Rz10, (2.1,0.2,0))
//          = (Rz10, (0.1,0.2,0)) -> sqrt(0.05) = 0.2236068 m, 10 deg
class RpeHandCase : public ::testing::Test {
 protected:
  io::Trajectory gt_{{0.0, pose(0, 0.0, 0.0)}, {1.0, pose(0, 1.0, 0.0)}, {2.0, pose(0, 2.0, 0.0)}};
  io::Trajectory est_{{0.0, pose(0, 0.0, 0.0)}, {1.0, pose(0, 1.1, 0.0)}, {2.0, pose(10, 2.1, 0.2)}};
  std::vector<AssociatedPair> pairs_ = associate(gt_, est_, 0.02);
};

TEST_F(RpeHandCase, OneSecondGap) {
  ASSERT_EQ(pairs_.size(), 3u);
  const RpeResult r = compute_rpe(gt_, est_, pairs_, {RpeGapKind::kTime, 1.0, 10, 0.1});
  ASSERT_EQ(r.translation_m.count, 2u);
  EXPECT_NEAR(r.translation_m.rmse, 0.158113883, 1e-9);
  EXPECT_NEAR(r.translation_m.mean, 0.15, 1e-12);
  EXPECT_NEAR(r.translation_m.max, 0.2, 1e-12);
  EXPECT_NEAR(r.rotation_deg.rmse, 7.0710678, 1e-6);
  EXPECT_NEAR(r.rotation_deg.mean, 5.0, 1e-9);
}

TEST_F(RpeHandCase, FrameGapMatchesTimeGap) {
  const RpeResult one = compute_rpe(gt_, est_, pairs_, {RpeGapKind::kFrames, 1.0, 1, 0.1});
  EXPECT_EQ(one.translation_m.count, 2u);
  EXPECT_NEAR(one.translation_m.rmse, 0.158113883, 1e-9);
  EXPECT_NEAR(one.rotation_deg.mean, 5.0, 1e-9);
  const RpeResult two_frames = compute_rpe(gt_, est_, pairs_, {RpeGapKind::kFrames, 1.0, 2, 0.1});
  const RpeResult two_s = compute_rpe(gt_, est_, pairs_, {RpeGapKind::kTime, 2.0, 10, 0.1});
  for (const RpeResult* r : {&two_frames, &two_s}) {
    ASSERT_EQ(r->translation_m.count, 1u);
    EXPECT_NEAR(r->translation_m.rmse, 0.2236068, 1e-7);
    EXPECT_NEAR(r->rotation_deg.rmse, 10.0, 1e-9);
  }
}

TEST_F(RpeHandCase, MissingPartnerOutsideToleranceIsSkipped) {
  // Without the middle estimate, no pair is 1 s apart (+-0.1 s): no RPE.
  const io::Trajectory est{est_[0], est_[2]};
  const auto pairs = associate(gt_, est, 0.02);
  ASSERT_EQ(pairs.size(), 2u);
  const RpeResult r = compute_rpe(gt_, est, pairs, {RpeGapKind::kTime, 1.0, 10, 0.1});
  EXPECT_EQ(r.translation_m.count, 0u);
  EXPECT_TRUE(std::isnan(r.translation_m.rmse));
  // With a 1 s tolerance the 2 s pair is accepted as the nearest.
  const RpeResult loose = compute_rpe(gt_, est, pairs, {RpeGapKind::kTime, 1.0, 10, 1.0});
  EXPECT_EQ(loose.translation_m.count, 1u);
  EXPECT_NEAR(loose.translation_m.rmse, 0.2236068, 1e-7);
}

TEST(Rpe, TenFrameGapOnConstantDrift) {
  // Estimate runs 2 % long along x: every 10-frame pair (1 m of GT travel)
  // has a 0.02 m error; 30 poses -> 20 pairs.
  io::Trajectory gt;
  io::Trajectory est;
  for (int i = 0; i < 30; ++i) {
    gt.push_back({0.1 * i, pose(0, 0.1 * i, 0.0)});
    est.push_back({0.1 * i, pose(0, 0.102 * i, 0.0)});
  }
  const auto pairs = associate(gt, est, 0.02);
  const RpeResult r = compute_rpe(gt, est, pairs, {RpeGapKind::kFrames, 1.0, 10, 0.1});
  EXPECT_EQ(r.translation_m.count, 20u);
  EXPECT_NEAR(r.translation_m.rmse, 0.02, 1e-9);
  EXPECT_NEAR(r.translation_m.max, 0.02, 1e-9);
  EXPECT_NEAR(r.rotation_deg.max, 0.0, 1e-9);
}

TEST(ErrorStatsTest, HandValues) {
  // {3, 1, 4, 1, 5}: mean 2.8, median 3, rmse sqrt(52/5); deviations
  // 0.2, -1.8, 1.2, -1.8, 2.2 -> squares sum 12.8 -> std sqrt(12.8/5) = 1.6.
  const ErrorStats s = compute_stats({3.0, 1.0, 4.0, 1.0, 5.0});
  EXPECT_EQ(s.count, 5u);
  EXPECT_NEAR(s.mean, 2.8, 1e-12);
  EXPECT_NEAR(s.median, 3.0, 1e-12);
  EXPECT_NEAR(s.rmse, std::sqrt(52.0 / 5.0), 1e-12);
  EXPECT_NEAR(s.std, 1.6, 1e-12);
  EXPECT_EQ(s.min, 1.0);
  EXPECT_EQ(s.max, 5.0);
  EXPECT_NEAR(compute_stats({1.0, 2.0, 4.0, 10.0}).median, 3.0, 1e-12);
  EXPECT_TRUE(std::isnan(compute_stats({}).rmse));
}

}  // namespace
}  // namespace sitepose::eval
