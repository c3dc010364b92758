#include "sitepose/sim/motion.hpp"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace sitepose::sim
