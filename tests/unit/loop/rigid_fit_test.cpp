// The closed-form rigid fit and its RANSAC (loop/rigid_fit.hpp).

#include "sitepose/loop/rigid_fit.hpp"

#include <gtest/gtest.h>

#include <random>

namespace sitepose::loop {
namespace {

SE3 some_transform() {
  Vector6d xi;
  xi << 1.5, -0.7, 4.2, 0.3, -0.5, 1.1;
  return SE3::exp(xi);
}

std::vector<Eigen::Vector3d> random_points(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) out.emplace_back(u(rng), u(rng), u(rng));
  return out;
}

double distance(const SE3& a, const SE3& b) { return (a.inverse() * b).log().norm(); }

// fit_rigid on `n` random points and their exact images under a known
// transform gives that transform.
void expect_exact_fit(int n, std::uint64_t seed) {
  const SE3 T_a_b = some_transform();
  const std::vector<Eigen::Vector3d> p_b = random_points(n, seed);
  std::vector<Eigen::Vector3d> p_a;
  for (const auto& p : p_b) p_a.push_back(T_a_b * p);
  const Expected<SE3> fit = fit_rigid(p_a, p_b);
  ASSERT_TRUE(fit.has_value()) << fit.error().message;
  EXPECT_LT(distance(*fit, T_a_b), 1e-9);
}

TEST(RigidFit, IsExactOnNoiseFreePoints) { expect_exact_fit(30, 1); }

TEST(RigidFit, IsExactOnThreePoints) { expect_exact_fit(3, 2); }

TEST(RigidFit, NeverReturnsAReflection) {
  // Mirrored points: the best proper rotation, det(R) = +1.
  const std::vector<Eigen::Vector3d> p_b = random_points(10, 3);
  std::vector<Eigen::Vector3d> p_a;
  for (const auto& p : p_b) p_a.emplace_back(-p.x(), p.y(), p.z());
  const Expected<SE3> fit = fit_rigid(p_a, p_b);
  ASSERT_TRUE(fit.has_value());
  EXPECT_NEAR(fit->rotation_matrix().determinant(), 1.0, 1e-12);
}

TEST(RigidFit, RefusesCollinearAndTooFewPoints) {
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 5; ++i) line.emplace_back(i, 2.0 * i, -i);
  EXPECT_FALSE(fit_rigid(line, line).has_value());
  const std::vector<Eigen::Vector3d> two = random_points(2, 4);
  EXPECT_FALSE(fit_rigid(two, two).has_value());
  EXPECT_FALSE(fit_rigid(random_points(4, 5), random_points(5, 5)).has_value());
}

TEST(RigidRansac, RejectsOutliersAndRecoversTheTransform) {
  const SE3 T_a_b = some_transform();
  const std::vector<Eigen::Vector3d> p_b = random_points(100, 6);
  std::vector<Eigen::Vector3d> p_a;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::vector<bool> outlier(p_b.size(), false);
  for (std::size_t i = 0; i < p_b.size(); ++i) {
    // 40 % outliers: anywhere in the volume.
    outlier[i] = i % 5 < 2;
    p_a.push_back(outlier[i] ? Eigen::Vector3d(u(rng), u(rng), u(rng))
                             : T_a_b * p_b[i] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  const auto is_inlier = [&](const SE3& T, int i) {
    return (p_a[static_cast<std::size_t>(i)] - T * p_b[static_cast<std::size_t>(i)]).norm() < 0.05;
  };
  const Expected<RigidRansacResult> r = ransac_rigid(p_a, p_b, is_inlier);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_LT((r->T_a_b.translation() - T_a_b.translation()).norm(), 0.01);
  EXPECT_LT(rotation_angle_rad(r->T_a_b.rotation().conjugate() * T_a_b.rotation()), 1e-3);
  for (int i : r->inliers)
    EXPECT_FALSE(outlier[static_cast<std::size_t>(i)]) << "outlier " << i << " accepted";
  EXPECT_EQ(r->inliers.size(), 60U);
}

TEST(RigidRansac, RefusesPairsWithoutACommonTransform) {
  const std::vector<Eigen::Vector3d> p_a = random_points(60, 8);
  const std::vector<Eigen::Vector3d> p_b = random_points(60, 9);
  const auto is_inlier = [&](const SE3& T, int i) {
    return (p_a[static_cast<std::size_t>(i)] - T * p_b[static_cast<std::size_t>(i)]).norm() < 0.05;
  };
  const Expected<RigidRansacResult> r = ransac_rigid(p_a, p_b, is_inlier);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace sitepose::loop
