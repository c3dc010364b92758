#include "sitepose/geo/robust_alignment.hpp"

#include <random>

#include <gtest/gtest.h>

namespace sitepose::geo {
namespace {

TEST(RobustAlignment, RecoversTransformDespiteOutliers) {
  const SE3 T_true(Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(0.1, 0.2, 1.0).normalized())),
                   Eigen::Vector3d(3.0, -4.0, 0.5));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<bool> is_outlier;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), 0.1 * u(rng));
    Eigen::Vector3d q = T_true * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const bool outlier = i % 3 == 0;  // 34 %
    if (outlier) q += Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.2;
    src.push_back(p);
    dst.push_back(q);
    is_outlier.push_back(outlier && (q - T_true * p).norm() > 0.1);
  }
  auto fit = robust_umeyama_se3(src, dst, {});
  ASSERT_TRUE(fit.has_value()) << fit.error().message;
  EXPECT_LT((fit->T_dst_src.translation() - T_true.translation()).norm(), 0.01);
  EXPECT_LT(rotation_angle_rad(fit->T_dst_src.rotation() * T_true.rotation().inverse()), 1e-3);
  for (std::size_t i = 0; i < src.size(); ++i) {
    if (is_outlier[i]) {
      EXPECT_FALSE(fit->inlier[i]) << i;
    }
  }
  EXPECT_GT(fit->num_inliers, 125);
  EXPECT_LT(fit->inlier_rms_m, 0.025);
  // The plain least-squares fit is visibly pulled by the outliers.
  std::vector<Eigen::Vector3d> all_src = src, all_dst = dst;
  RobustAlignmentOptions huge;
  huge.inlier_threshold_m = 1e6;
  auto plain = robust_umeyama_se3(all_src, all_dst, huge);
  ASSERT_TRUE(plain.has_value());
  EXPECT_GT((plain->T_dst_src.translation() - T_true.translation()).norm(), 0.05);
}

TEST(RobustAlignment, RejectsBadInput) {
  std::vector<Eigen::Vector3d> three = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                        Eigen::Vector3d(0, 1, 0)};
  EXPECT_FALSE(robust_umeyama_se3(three, {three[0], three[1]}, {}).has_value());
  EXPECT_FALSE(robust_umeyama_se3({three[0], three[1]}, {three[0], three[1]}, {}).has_value());
  RobustAlignmentOptions bad;
  bad.inlier_threshold_m = 0.0;
  EXPECT_FALSE(robust_umeyama_se3(three, three, bad).has_value());
  // Collinear points: no sample can fix the rotation.
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 10; ++i) line.emplace_back(i, 2.0 * i, 0.0);
  auto r = robust_umeyama_se3(line, line, {});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().code, ErrorCode::kRuntime);
}

}  // namespace
}  // namespace sitepose::geo
