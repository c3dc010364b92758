#include "sitepose/eval/time_offset.hpp"

#include <gtest/gtest.h>

#include <random>

#include "sitepose/eval/evaluate.hpp"
#include "test_trajectories.hpp"

namespace sitepose::eval {
namespace {

using testing::curvy_pose;
using testing::curvy_trajectory;
using testing::some_rigid_transform;
using testing::transformed;

// Estimate of `gt` in another world frame, stamped on a clock that is
// offset_s behind (t_est = t_gt - offset_s), with position noise.
io::Trajectory offset_estimate(const io::Trajectory& gt, double offset_s, double sigma_m,
                               unsigned seed) {
  io::Trajectory est = transformed(gt, some_rigid_transform());
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_m);
  for (auto& p : est) {
    p.t_s -= offset_s;
    const Eigen::Vector3d n(noise(rng), noise(rng), noise(rng));
    p.T_world_cam = SE3(p.T_world_cam.rotation(), p.T_world_cam.translation() + n);
  }
  return est;
}

TEST(TimeOffset, RecoversPointThreeSecondsThroughEvaluate) {
  const io::Trajectory gt = curvy_trajectory(600, 10.0);
  const io::Trajectory est = offset_estimate(gt, 0.3, 0.02, 3);
  EvalOptions options;
  // Without the search, 0.3 s is exactly 3 GT frames: each estimate pairs
  // with the wrong frame and the ATE is dominated by 0.3 s of motion.
  const auto unsearched = evaluate(gt, est, options);
  ASSERT_TRUE(unsearched.has_value()) << unsearched.error().message;
  EXPECT_GT(unsearched->ate_m.rmse, 0.2);
  options.time_offset_search_range_s = 1.0;
  const auto result = evaluate(gt, est, options);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  EXPECT_TRUE(result->time_offset_searched);
  EXPECT_NEAR(result->time_offset_s, 0.3, 0.02);
  EXPECT_EQ(result->associated, 600u);  // every estimate lands on its GT frame
  EXPECT_NEAR(result->ate_m.rmse, 0.02 * std::sqrt(3.0), 0.1 * 0.02 * std::sqrt(3.0));
}

TEST(TimeOffset, RecoversASubFrameNegativeOffset) {
  // Estimate sampled between GT frames: t_est = t_gt + 0.137 s, so the
  // offset is -0.137 s, not a multiple of the 0.1 s GT period.
  const io::Trajectory gt = curvy_trajectory(600, 10.0, 0.0);
  io::Trajectory est;
  for (int i = 10; i < 590; ++i) {
    const double t = i * 0.1 + 0.043;  // time on the GT clock
    est.push_back({t + 0.137, some_rigid_transform() * curvy_pose(t)});
  }
  const auto result = search_time_offset(gt, est, 0.5);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  EXPECT_NEAR(result->time_offset_s, -0.137, 0.005);
  EXPECT_LT(result->ate_rmse_m, 0.01);  // linear-interpolation error only
  EXPECT_GT(result->evaluations, 10);
}

TEST(TimeOffset, ZeroOffsetStaysZero) {
  const io::Trajectory gt = curvy_trajectory(300, 10.0);
  const io::Trajectory est = offset_estimate(gt, 0.0, 0.01, 5);
  const auto result = search_time_offset(gt, est, 0.8);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  EXPECT_NEAR(result->time_offset_s, 0.0, 0.02);
}

TEST(TimeOffset, RejectsBadRangeAndTooShortSequences) {
  const io::Trajectory gt = curvy_trajectory(50, 10.0);  // 4.9 s
  const io::Trajectory est = offset_estimate(gt, 0.0, 0.0, 1);
  EXPECT_FALSE(search_time_offset(gt, est, 0.0).has_value());
  EXPECT_FALSE(search_time_offset(gt, est, -1.0).has_value());
  const auto too_long = search_time_offset(gt, est, 3.0);
  ASSERT_FALSE(too_long.has_value());
  EXPECT_EQ(too_long.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(too_long.error().message.find("smaller range"), std::string::npos)
      << too_long.error().message;
}

}  // namespace
}  // namespace sitepose::eval
