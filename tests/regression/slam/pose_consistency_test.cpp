// The published covariance against ground truth on a short static-scene
// run (experiments::run_nees, the daemon's published_pose with the shipped
// outputs.covariance). Over the first 60 frames the measured mean position
// NEES is 1.6 and 3.7 (seeds 1, 2; docs/daemon/pose_quality.md); over whole
// runs it is far above the chi-square band (map drift is not in the
// tracker's covariance), so this is a sanity band, not the consistency
// claim: it fails when the published covariance becomes grossly
// overconfident (e.g. the scale or floor lost) or grossly conservative.

#include <gtest/gtest.h>

#include <string>

#include "sitepose/experiments/pose_consistency.hpp"

namespace sitepose::experiments {
namespace {

TEST(PoseConsistency, StaticShortRunNeesWithinSanityBand) {
  auto source =
      open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/static.yaml", 60, std::nullopt, 640, 360);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kFull;
  auto result = run_nees(**source, config);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  ASSERT_EQ(result->anchor_frame, 0);
  ASSERT_GE(result->samples.size(), 55u);
  const double nees = result->mean_nees_position();
  EXPECT_GT(nees, 0.3);
  EXPECT_LT(nees, 10.0);
  EXPECT_GE(result->bound_coverage(), 0.8);
  // Errors stay far below the shipped 0.10 m alert limit here: no alert.
  EXPECT_EQ(result->alerts(), 0);
  EXPECT_EQ(result->missed_detections(), 0);
}

}  // namespace
}  // namespace sitepose::experiments
