#include "sitepose/sim/motion.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace sitepose::sim {
namespace {

TEST(SpeedProfile, RampsSmoothlyAndDistanceIsTheIntegralOfSpeed) {
  const SpeedProfile p({{1.0, 1.0}, {10.0, 0.0}, {15.0, -0.6}}, 0.25);
  EXPECT_EQ(p.speed_mps(0.5), 0.0);
  EXPECT_EQ(p.distance_m(0.5), 0.0);
  EXPECT_NEAR(p.speed_mps(5.1), 1.0, 1e-12);  // ramp of 4 s done
  EXPECT_NEAR(p.speed_mps(20.0), -0.6, 1e-12);
  double integral = 0.0, max_accel = 0.0, last_v = 0.0;
  const double dt = 1e-3;
  for (double t = 0.0; t < 30.0; t += dt) {
    const double v = p.speed_mps(t + 0.5 * dt);
    integral += v * dt;
    max_accel = std::max(max_accel, std::abs(v - last_v) / dt);
    last_v = v;
    EXPECT_LE(std::abs(v), 1.0 + 1e-12);
  }
  EXPECT_NEAR(p.distance_m(30.0), integral, 1e-4);
  // Half-cosine ramps peak at pi/2 * accel.
  EXPECT_LT(max_accel, 0.25 * M_PI / 2 + 0.01);
  EXPECT_GT(max_accel, 0.25);
}

TEST(SpeedProfile, StandsExactlyStillAfterStopping) {
  const SpeedProfile p({{0.0, 1.0}, {5.0, 0.0}}, 0.5);
  EXPECT_EQ(p.distance_m(9.0), p.distance_m(12.0));  // exact: `moving` compares poses
  EXPECT_GT(p.distance_m(6.0), p.distance_m(5.5));
}

TEST(Polyline, WalksByArcLengthAndClampsAtTheEnds) {
  const Polyline line({{0, 0}, {3, 4}, {3, 10}});
  EXPECT_DOUBLE_EQ(line.length_m(), 11.0);
  EXPECT_TRUE(line.position(2.5).isApprox(Eigen::Vector2d(1.5, 2.0)));
  EXPECT_TRUE(line.position(7.0).isApprox(Eigen::Vector2d(3.0, 6.0)));
  EXPECT_TRUE(line.position(50.0).isApprox(Eigen::Vector2d(3.0, 10.0)));
  EXPECT_TRUE(line.position(-1.0).isApprox(Eigen::Vector2d(0.0, 0.0)));
  EXPECT_NEAR(line.heading_rad(7.0), M_PI / 2, 1e-12);
}

// A right turn of 90 deg rounded with a 4 m radius: the arc starts and ends
// 4 m (r tan 45 deg) from the corner, every point of it is 4 m from the
// centre, the heading turns in small steps, and no point comes twice.
TEST(RoundedCorners, ReplacesACornerByATangentArcOfTheRadius) {
  const std::vector<Eigen::Vector2d> rounded = rounded_corners({{0, 0}, {10, 0}, {10, -10}}, 4.0, 0.1);
  ASSERT_GT(rounded.size(), 10u);
  EXPECT_TRUE(rounded.front().isApprox(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(rounded.back().isApprox(Eigen::Vector2d(10, -10)));
  EXPECT_TRUE(rounded[1].isApprox(Eigen::Vector2d(6, 0)));                     // the arc's start
  EXPECT_TRUE(rounded[rounded.size() - 2].isApprox(Eigen::Vector2d(10, -4)));  // its end
  const Eigen::Vector2d centre(6, -4);
  for (std::size_t i = 1; i + 1 < rounded.size(); ++i) EXPECT_NEAR((rounded[i] - centre).norm(), 4.0, 1e-9);
  const Polyline path(rounded);
  EXPECT_NEAR(path.length_m(), 6.0 + 2.0 * M_PI + 6.0, 0.01);  // the arc: r pi / 2
  double largest_step_rad = 0.0;
  for (double s = 0.0; s + 0.05 < path.length_m(); s += 0.05) {
    largest_step_rad = std::max(largest_step_rad, std::abs(path.heading_rad(s + 0.05) - path.heading_rad(s)));
  }
  EXPECT_LT(largest_step_rad, 0.03);  // 0.1 m of a 4 m arc: 0.025 rad
  EXPECT_NEAR(path.heading_rad(path.length_m()), -M_PI / 2, 1e-9);
  for (std::size_t i = 1; i < rounded.size(); ++i) EXPECT_GT((rounded[i] - rounded[i - 1]).norm(), 1e-9);
}

// Two corners sharing a short segment: each arc takes at most half of it
// (a smaller radius there), so they meet without a point twice; a straight
// run and a zero radius are left as given.
TEST(RoundedCorners, TightCornersShrinkTheRadiusAndStraightRunsStay) {
  const std::vector<Eigen::Vector2d> rounded =
      rounded_corners({{0, 0}, {10, 0}, {10, -2}, {0, -2}}, 4.0, 0.1);
  for (std::size_t i = 1; i < rounded.size(); ++i) EXPECT_GT((rounded[i] - rounded[i - 1]).norm(), 1e-9);
  EXPECT_TRUE(std::any_of(rounded.begin(), rounded.end(),
                          [](const Eigen::Vector2d& p) { return p.isApprox(Eigen::Vector2d(10, -1)); }));
  const std::vector<Eigen::Vector2d> straight{{0, 0}, {5, 0}, {9, 0}};
  EXPECT_EQ(rounded_corners(straight, 4.0), straight);
  const std::vector<Eigen::Vector2d> sharp{{0, 0}, {5, 0}, {5, 5}};
  EXPECT_EQ(rounded_corners(sharp, 0.0), sharp);
}

}  // namespace
}  // namespace sitepose::sim
