#include "sitepose/optim/local_ba.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <iostream>

#include "synthetic_scene.hpp"

namespace sitepose::optim {
namespace {

using namespace testing;  // NOLINT: test helpers

constexpr double kDegToRad = M_PI / 180.0;

struct MapScene {
  std::vector<SE3> T_cam_world_true;
  std::vector<Eigen::Vector3d> p_world_true;
  LocalBaInput input;  // perturbed poses / points, noisy observations
  std::vector<std::uint8_t> gross_outlier;  // per observation
};

// Eight keyframes 1 m apart along a slightly turning path, points 4-30 m in
// front (stereo below 20 m, mono beyond); keyframes 0 and 1 are the fixed
// outer ring. Free poses are perturbed by 5 cm / 0.5 deg, points by ~10 cm.
MapScene make_map_scene(double outlier_fraction, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const StereoCamera camera = test_camera();
  MapScene s;
  constexpr int kKeyframes = 8;
  const SE3 T_world_start = test_pose_world_cam();
  for (int k = 0; k < kKeyframes; ++k) {
    Vector6d xi;
    xi << 0.1 * k, 0.02 * k, 1.0 * k, 0.0, 0.02 * k, 0.0;
    s.T_cam_world_true.push_back((T_world_start * SE3::exp(xi)).inverse());
  }
  const SE3 T_world_mid = s.T_cam_world_true[kKeyframes / 2].inverse();
  for (int i = 0; i < 300; ++i) {
    s.p_world_true.push_back(T_world_mid * random_point_cam(camera, 4.0, 30.0, rng));
  }
  std::uniform_int_distribution<int> level(0, 3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < kKeyframes; ++k) {
    for (int p = 0; p < static_cast<int>(s.p_world_true.size()); ++p) {
      const Eigen::Vector3d p_cam = s.T_cam_world_true[k] * s.p_world_true[p];
      if (p_cam.z() < 1.0 || !camera.in_image(camera.project(p_cam), 5.0)) continue;
      PoseObservation o = exact_observation(camera, s.T_cam_world_true[k], s.p_world_true[p], level(rng),
                                            /*mono_only=*/false);
      const bool outlier = unit(rng) < outlier_fraction;
      if (outlier) {
        make_gross_outlier(camera, o, rng);
      } else {
        add_noise(o, rng);
      }
      s.input.observations.push_back({k, p, o.uv_left_px, o.u_right_px, o.sigma2_px2});
      s.gross_outlier.push_back(outlier ? 1 : 0);
    }
  }
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < kKeyframes; ++k) {
    const bool fixed = k < 2;
    s.input.keyframe_fixed.push_back(fixed ? 1 : 0);
    const SE3 T_world_cam = s.T_cam_world_true[k].inverse();
    s.input.T_cam_world.push_back(fixed ? s.T_cam_world_true[k]
                                        : perturb(T_world_cam, 0.05, 0.5 * kDegToRad, rng).inverse());
  }
  for (const Eigen::Vector3d& p : s.p_world_true) {
    s.input.p_world.push_back(p + 0.1 * Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  return s;
}

struct Errors {
  double max_translation_m = 0.0;
  double max_rotation_rad = 0.0;
  double point_rms_m = 0.0;  // over points with >= 2 stereo observations
};

// Errors of (T_cam_world, p) against reference values (the truth, or another
// solution).
Errors errors(const MapScene& s, const std::vector<SE3>& T_cam_world, const std::vector<Eigen::Vector3d>& p,
              const std::vector<SE3>& T_cam_world_ref, const std::vector<Eigen::Vector3d>& p_ref) {
  Errors e;
  for (std::size_t k = 0; k < T_cam_world.size(); ++k) {
    const SE3 a = T_cam_world[k].inverse();
    const SE3 b = T_cam_world_ref[k].inverse();
    e.max_translation_m = std::max(e.max_translation_m, translation_error_m(a, b));
    e.max_rotation_rad = std::max(e.max_rotation_rad, rotation_error_rad(a, b));
  }
  std::vector<int> stereo_count(p.size(), 0);
  for (const LocalBaObservation& o : s.input.observations) stereo_count[o.point_index] += o.is_stereo();
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (stereo_count[i] < 2) continue;
    sum += (p[i] - p_ref[i]).squaredNorm();
    ++n;
  }
  e.point_rms_m = std::sqrt(sum / std::max(n, 1));
  return e;
}

TEST(LocalBa, ReducesPoseAndPointErrorsAndKeepsFixedKeyframes) {
  const MapScene s = make_map_scene(0.05, 3);
  const LocalBa ba(test_camera(), config::MappingConfig{}, config::TrackingConfig{});
  auto result = ba.solve(s.input, nullptr);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  EXPECT_FALSE(result->aborted);
  EXPECT_EQ(result->stages_run, 2);
  EXPECT_LT(result->final_cost, result->initial_cost);

  // Fixed keyframes come back bit for bit.
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(result->T_cam_world[k].translation(), s.input.T_cam_world[k].translation());
    EXPECT_EQ(result->T_cam_world[k].rotation().coeffs(), s.input.T_cam_world[k].rotation().coeffs());
  }
  const Errors before =
      errors(s, s.input.T_cam_world, s.input.p_world, s.T_cam_world_true, s.p_world_true);
  const Errors after = errors(s, result->T_cam_world, result->p_world, s.T_cam_world_true, s.p_world_true);
  EXPECT_GT(before.max_translation_m, 0.04);
  EXPECT_LT(after.max_translation_m, 0.5 * before.max_translation_m);
  EXPECT_LT(after.max_rotation_rad, 0.5 * before.max_rotation_rad);
  EXPECT_LT(after.point_rms_m, 0.5 * before.point_rms_m);

  // What is left is the noise floor: started from the truth, the same
  // problem converges to the same minimum.
  LocalBaInput from_truth = s.input;
  from_truth.T_cam_world = s.T_cam_world_true;
  from_truth.p_world = s.p_world_true;
  auto reference = ba.solve(from_truth, nullptr);
  ASSERT_TRUE(reference.has_value());
  const Errors gap =
      errors(s, result->T_cam_world, result->p_world, reference->T_cam_world, reference->p_world);
  EXPECT_LT(gap.max_translation_m, 0.002);
  EXPECT_LT(gap.max_rotation_rad, 0.01 * kDegToRad);
  EXPECT_LT(gap.point_rms_m, 0.01);
  std::cerr << "DBG before " << before.max_translation_m << " " << before.max_rotation_rad << " " << before.point_rms_m
   << " after " << after.max_translation_m << " " << after.max_rotation_rad << " " << after.point_rms_m
   << " gap " << gap.max_translation_m << " " << gap.max_rotation_rad << " " << gap.point_rms_m << "\n";

  // Every gross outlier is reported; few clean observations are.
  std::vector<std::uint8_t> flagged(s.input.observations.size(), 0);
  for (int i : result->outlier_observations) flagged[i] = 1;
  int outliers = 0;
  int clean_flagged = 0;
  int clean = 0;
  for (std::size_t i = 0; i < flagged.size(); ++i) {
    if (s.gross_outlier[i]) {
      ++outliers;
      EXPECT_TRUE(flagged[i]) << "observation " << i;
    } else {
      ++clean;
      clean_flagged += flagged[i];
    }
  }
  EXPECT_GT(outliers, 20);
  EXPECT_LT(clean_flagged, 0.1 * clean);
}

TEST(LocalBa, StopFlagSetBeforehandReturnsInputUnchanged) {
  const MapScene s = make_map_scene(0.0, 4);
  const LocalBa ba(test_camera(), config::MappingConfig{}, config::TrackingConfig{});
  const std::atomic<bool> stop{true};
  auto result = ba.solve(s.input, &stop);
  ASSERT_TRUE(result.has_value());
  EXPECT_TRUE(result->aborted);
  EXPECT_EQ(result->stages_run, 0);
  EXPECT_EQ(result->iterations, 0);
  for (std::size_t k = 0; k < s.input.T_cam_world.size(); ++k) {
    EXPECT_TRUE(result->T_cam_world[k].translation().isApprox(s.input.T_cam_world[k].translation(), 1e-15));
  }
  for (std::size_t p = 0; p < s.input.p_world.size(); ++p) {
    EXPECT_EQ(result->p_world[p], s.input.p_world[p]);
  }
}

TEST(LocalBa, RespectsIterationBudget) {
  const MapScene s = make_map_scene(0.0, 5);
  config::MappingConfig mapping;
  mapping.local_ba_iterations = 2;  // stage 1: 1 iteration, stage 2: 2
  const LocalBa ba(test_camera(), mapping, config::TrackingConfig{});
  auto result = ba.solve(s.input, nullptr);
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->stages_run, 2);
  EXPECT_GE(result->iterations, 1);
  EXPECT_LE(result->iterations, 3);
}

TEST(LocalBa, InvalidInputNamesTheEntry) {
  MapScene s = make_map_scene(0.0, 6);
  const LocalBa ba(test_camera(), config::MappingConfig{}, config::TrackingConfig{});
  s.input.observations[4].point_index = 100000;
  auto bad_point = ba.solve(s.input, nullptr);
  ASSERT_FALSE(bad_point.has_value());
  EXPECT_EQ(bad_point.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(bad_point.error().message.find("observation 4"), std::string::npos);
  EXPECT_NE(bad_point.error().message.find("point_index 100000"), std::string::npos);

  s.input.observations[4].point_index = 0;
  s.input.keyframe_fixed.pop_back();
  auto bad_fixed = ba.solve(s.input, nullptr);
  ASSERT_FALSE(bad_fixed.has_value());
  EXPECT_NE(bad_fixed.error().message.find("keyframe_fixed"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::optim
