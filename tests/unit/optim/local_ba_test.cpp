#include "sitepose/optim/local_ba.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sitepose/testing/pose_scene.hpp"

namespace sitepose::optim {
namespace {

using namespace testing;  // NOLINT: test helpers

struct Errors {
  double max_translation_m = 0.0;
  double max_rotation_rad = 0.0;
  double point_rms_m = 0.0;  // over the points in the mask
};

// Points the mapper keeps with well-observed depth: >= 2 stereo observations
// that local BA did not report as outliers. (Far mono-only points have the
// weak depth of forward motion; a point whose observations are all
// reported is erased by the mapper.)
std::vector<std::uint8_t> well_observed_points(const MapScene& s, const LocalBaResult& result) {
  std::vector<std::uint8_t> outlier(s.input.observations.size(), 0);
  for (int i : result.outlier_observations) outlier[i] = 1;
  std::vector<int> stereo_inliers(s.p_world_true.size(), 0);
  for (std::size_t i = 0; i < outlier.size(); ++i) {
    const LocalBaObservation& o = s.input.observations[i];
    if (!outlier[i] && o.is_stereo()) ++stereo_inliers[o.point_index];
  }
  std::vector<std::uint8_t> mask(s.p_world_true.size(), 0);
  for (std::size_t p = 0; p < mask.size(); ++p) mask[p] = stereo_inliers[p] >= 2 ? 1 : 0;
  return mask;
}

// Errors of (T_cam_world, p) against reference values (the truth, or another
// solution).
Errors errors(const std::vector<SE3>& T_cam_world, const std::vector<Eigen::Vector3d>& p,
              const std::vector<SE3>& T_cam_world_ref, const std::vector<Eigen::Vector3d>& p_ref,
              const std::vector<std::uint8_t>& point_mask) {
  Errors e;
  for (std::size_t k = 0; k < T_cam_world.size(); ++k) {
    const SE3 a = T_cam_world[k].inverse();
    const SE3 b = T_cam_world_ref[k].inverse();
    e.max_translation_m = std::max(e.max_translation_m, translation_error_m(a, b));
    e.max_rotation_rad = std::max(e.max_rotation_rad, rotation_error_rad(a, b));
  }
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!point_mask[i]) continue;
    sum += (p[i] - p_ref[i]).squaredNorm();
    ++n;
  }
  e.point_rms_m = std::sqrt(sum / std::max(n, 1));
  return e;
}

TEST(LocalBa, ReducesPoseAndPointErrorsAndKeepsFixedKeyframes) {
  const MapScene s = make_map_scene(0.05, 3);
  const LocalBa ba(hd_camera(), config::MappingConfig{}, config::TrackingConfig{});
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
  const std::vector<std::uint8_t> kept = well_observed_points(s, *result);
  int kept_count = 0;
  for (std::uint8_t k : kept) kept_count += k;
  EXPECT_GT(kept_count, 150);
  const Errors before = errors(s.input.T_cam_world, s.input.p_world, s.T_cam_world_true, s.p_world_true, kept);
  const Errors after = errors(result->T_cam_world, result->p_world, s.T_cam_world_true, s.p_world_true, kept);
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
      errors(result->T_cam_world, result->p_world, reference->T_cam_world, reference->p_world, kept);
  EXPECT_LT(gap.max_translation_m, 0.002);
  EXPECT_LT(gap.max_rotation_rad, 0.01 * kDegToRad);
  EXPECT_LT(gap.point_rms_m, 0.01);

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

TEST(LocalBa, AllKeyframesFixedRefinesPointsOnly) {
  MapScene s = make_map_scene(0.0, 7);
  s.input.T_cam_world = s.T_cam_world_true;
  for (std::uint8_t& fixed : s.input.keyframe_fixed) fixed = 1;
  const LocalBa ba(hd_camera(), config::MappingConfig{}, config::TrackingConfig{});
  auto result = ba.solve(s.input, nullptr);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  EXPECT_EQ(result->stages_run, 2);
  for (std::size_t k = 0; k < s.input.T_cam_world.size(); ++k) {
    EXPECT_EQ(result->T_cam_world[k].translation(), s.input.T_cam_world[k].translation());
  }
  const std::vector<std::uint8_t> kept = well_observed_points(s, *result);
  const Errors before = errors(s.input.T_cam_world, s.input.p_world, s.T_cam_world_true, s.p_world_true, kept);
  const Errors after = errors(result->T_cam_world, result->p_world, s.T_cam_world_true, s.p_world_true, kept);
  EXPECT_LT(after.point_rms_m, 0.5 * before.point_rms_m);
}

TEST(LocalBa, StopFlagSetBeforehandReturnsInputUnchanged) {
  const MapScene s = make_map_scene(0.0, 4);
  const LocalBa ba(hd_camera(), config::MappingConfig{}, config::TrackingConfig{});
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
  const LocalBa ba(hd_camera(), mapping, config::TrackingConfig{});
  auto result = ba.solve(s.input, nullptr);
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->stages_run, 2);
  EXPECT_GE(result->iterations, 1);
  EXPECT_LE(result->iterations, 3);
}

TEST(LocalBa, InvalidInputNamesTheEntry) {
  MapScene s = make_map_scene(0.0, 6);
  const LocalBa ba(hd_camera(), config::MappingConfig{}, config::TrackingConfig{});
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
