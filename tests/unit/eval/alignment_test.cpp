#include "sitepose/eval/alignment.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/SVD>

#include "sitepose/eval/evaluate.hpp"
#include "test_trajectories.hpp"

namespace sitepose::eval {
namespace {

using testing::curvy_trajectory;
using testing::some_rigid_transform;
using testing::transformed;

TEST(Umeyama, RecoversAKnownRigidTransform) {
  const io::Trajectory gt = curvy_trajectory(300, 10.0);
  const SE3 T_other_world = some_rigid_transform();
  const io::Trajectory est = transformed(gt, T_other_world);
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    src.push_back(est[i].T_world_cam.translation());
    dst.push_back(gt[i].T_world_cam.translation());
  }
  const auto T = umeyama_se3(src, dst);
  ASSERT_TRUE(T.has_value()) << T.error().message;
  const SE3 expected = T_other_world.inverse();
  EXPECT_LT((T->translation() - expected.translation()).norm(), 1e-9);
  EXPECT_LT(rotation_angle_rad(T->rotation().inverse() * expected.rotation()), 1e-10);
}

TEST(Umeyama, MovedGroundTruthAlignsToZeroAte) {
  const io::Trajectory gt = curvy_trajectory(300, 10.0);
  const io::Trajectory est = transformed(gt, some_rigid_transform());
  const auto result = evaluate(gt, est, EvalOptions{});
  ASSERT_TRUE(result.has_value()) << result.error().message;
  EXPECT_EQ(result->associated, 300u);
  EXPECT_LT(result->ate_m.rmse, 1e-9);
  EXPECT_LT(result->ate_m.max, 1e-9);
  // Unaligned, the estimate is ~120 m away: alignment did the work.
  EXPECT_GT((est[0].T_world_cam.translation() - gt[0].T_world_cam.translation()).norm(), 50.0);
}

TEST(Umeyama, NeverReturnsAReflection) {
  // Mirror image (z -> -z) of a non-planar point set: the best rotation is
  // proper, and its error is non-zero.
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    src.push_back(p);
    dst.push_back(Eigen::Vector3d(p.x(), p.y(), -p.z()));
  }
  const auto T = umeyama_se3(src, dst);
  ASSERT_TRUE(T.has_value());
  EXPECT_NEAR(T->rotation_matrix().determinant(), 1.0, 1e-12);
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < src.size(); ++i) sum_sq += (dst[i] - (*T) * src[i]).squaredNorm();
  EXPECT_GT(sum_sq, 1.0);
}

TEST(Umeyama, CollinearPointsStillAlign) {
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  const SE3 T_true = some_rigid_transform();
  for (int i = 0; i < 20; ++i) {
    src.emplace_back(0.5 * i, 0.0, 0.0);
    dst.push_back(T_true * src.back());
  }
  const auto T = umeyama_se3(src, dst);
  ASSERT_TRUE(T.has_value());
  for (std::size_t i = 0; i < src.size(); ++i) {
    EXPECT_LT((dst[i] - (*T) * src[i]).norm(), 1e-9);
  }
}

TEST(Umeyama, IsotropicNoiseGivesSigmaRootThree) {
  // Per-axis N(0, sigma^2) on positions: E|e|^2 = 3 sigma^2, so the ATE
  // RMSE is sigma*sqrt(3) (less the 6 dof the alignment absorbs, ~0.3 %).
  const double sigma_m = 0.05;
  const io::Trajectory gt = curvy_trajectory(1000, 10.0);
  io::Trajectory est = transformed(gt, some_rigid_transform());
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, sigma_m);
  const SE3 T_other_world = some_rigid_transform();
  for (auto& p : est) {
    const Eigen::Vector3d n(noise(rng), noise(rng), noise(rng));
    p.T_world_cam = SE3(p.T_world_cam.rotation(), p.T_world_cam.translation() + n);
  }
  const auto result = evaluate(gt, est, EvalOptions{});
  ASSERT_TRUE(result.has_value()) << result.error().message;
  const double expected = sigma_m * std::sqrt(3.0);
  EXPECT_NEAR(result->ate_m.rmse, expected, 0.1 * expected);
  // The alignment found the frame despite the noise.
  EXPECT_LT((result->T_gt_est.translation() - T_other_world.inverse().translation()).norm(), 0.05);
}

// The closed form of the paper written out (eq. 38-43, scale 1): the
// alignment through Eigen::umeyama must give the same transform on noisy
// points to 1e-9 (the hand-written version this replaced was this one).
SE3 reference_umeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    mean_src += src[i] / static_cast<double>(src.size());
    mean_dst += dst[i] / static_cast<double>(src.size());
  }
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) sigma += (dst[i] - mean_dst) * (src[i] - mean_src).transpose();
  sigma /= static_cast<double>(src.size());
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s(2, 2) = -1.0;
  const Eigen::Matrix3d R = svd.matrixU() * s * svd.matrixV().transpose();
  return SE3(R, mean_dst - R * mean_src);
}

TEST(Umeyama, MatchesThePapersClosedFormOnNoisyPoints) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (int trial = 0; trial < 20; ++trial) {
    const io::Trajectory gt = curvy_trajectory(50 + 10 * trial, 10.0);
    const io::Trajectory est = transformed(gt, some_rigid_transform());
    std::vector<Eigen::Vector3d> src, dst;
    for (std::size_t i = 0; i < gt.size(); ++i) {
      src.push_back(est[i].T_world_cam.translation() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
      dst.push_back(gt[i].T_world_cam.translation());
    }
    const auto T = umeyama_se3(src, dst);
    ASSERT_TRUE(T.has_value());
    const SE3 expected = reference_umeyama(src, dst);
    EXPECT_LT((T->matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
  }
}

TEST(Umeyama, RejectsBadInput) {
  const std::vector<Eigen::Vector3d> two{Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()};
  EXPECT_FALSE(umeyama_se3(two, two).has_value());
  const std::vector<Eigen::Vector3d> three(3, Eigen::Vector3d::Zero());
  const auto mismatched = umeyama_se3(three, two);
  ASSERT_FALSE(mismatched.has_value());
  EXPECT_EQ(mismatched.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace sitepose::eval
