// The published covariance against ground truth over the whole static
// scenario (360 frames, 40 m travelled; experiments::run_nees: the daemon's
// published_pose with the shipped outputs.covariance, map-drift term
// included). The map drifts by up to 7 cm while the tracker's own 3-sigma
// bound stays near 2.4 cm: without the drift term the mean position NEES is
// 18.2 and the bound covers 44 % of the frames; with the shipped term 1.8
// and 99.4 % (seed 1, one of the calibration runs; docs/daemon/
// pose_quality.md has the calibration and the check on other renderings).
// So this fails when the drift term is lost or made far too small
// (overconfident), or grossly too large (NEES < 0.5).

#include <gtest/gtest.h>

#include <string>

#include "sitepose/experiments/pose_consistency.hpp"

namespace sitepose::experiments {
namespace {

TEST(PoseConsistency, StaticRunNeesConsistentWithTheMapDriftTerm) {
  auto source =
      open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/static.yaml", 0, std::nullopt, 640, 360);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kFull;
  auto result = run_nees(**source, config);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  ASSERT_EQ(result->anchor_frame, 0);
  ASSERT_GE(result->samples.size(), 350u);
  ASSERT_GT(result->samples.back().travelled_m, 35.0);
  // At most the chi2(3) mean (not overconfident on average); the band of
  // the mean for 359 independent frames, [2.75, 3.26], is too narrow for
  // strongly correlated successive errors.
  const double nees = result->mean_nees_position();
  EXPECT_GT(nees, 0.5);
  EXPECT_LT(nees, 3.3);
  EXPECT_GE(result->bound_coverage(), 0.97);
  // The errors (up to 7 cm) stay below the shipped 0.10 m alert limit: none
  // missed. (The bound reaches 0.10 m at the end, after 40 m: alerts are
  // expected from there on, so none are counted here.)
  EXPECT_EQ(result->missed_detections(), 0);
}

}  // namespace
}  // namespace sitepose::experiments
