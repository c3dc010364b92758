// Issue 24 "Robust when standing": the ego stands 24 s while a dump truck
// passes 3.5 m from the lens twice (up to ~80 % of the view hidden). Mode
// none has no detector to mask it, so the core itself must not follow it:
// no OK pose more than 0.05 m off, every OK pose scored against the ground
// truth without alignment. The rendering is the worst one measured before
// the standing test (480x270, seed 21: ATE 1.9965 m, 106 OK poses > 0.05 m
// off; docs/tracking/standing.md).

#include <gtest/gtest.h>

#include "blind_spell_run.hpp"

namespace sitepose::experiments {
namespace {

TEST(Standing, PassingTruckNeverGivesAWrongOkPoseInModeNone) {
  config::SiteposeConfig config;
  config.dynamic.mode = config::MaskingMode::kNone;
  auto source = open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/standing.yaml", 0, 21, 480, 270);
  ASSERT_TRUE(source.has_value()) << source.error().message;
  auto run = run_dynamic(**source, config);
  ASSERT_TRUE(run.has_value()) << run.error().message;
  ASSERT_TRUE(run->evaluation.has_value()) << run->evaluation_error;
  ASSERT_EQ(run->ground_truth.size(), static_cast<std::size_t>(run->frames));
  const std::vector<bool> never_hidden(run->frames, false);
  const blind_spell::BlackoutScore s = blind_spell::score(*run, never_hidden);
  std::printf(
      "standing 480x270 seed 21, mode none: %d frames, %d OK, ATE rmse %.4f m (max %.4f m), "
      "largest OK error %.4f m, OK poses > 0.05 m off: %d\n",
      run->frames, s.ok_visible_frames, run->evaluation->ate_m.rmse, run->evaluation->ate_m.max,
      s.max_ok_error_m, s.ok_frames_off);
  EXPECT_EQ(s.ok_frames_off, 0) << "largest error of an OK pose: " << s.max_ok_error_m << " m";
  // The bound; measured 0.0116 m with 164 of 204 frames OK (the
  // rest LOST or RECOVERING while the truck hides the view).
  EXPECT_LE(run->evaluation->ate_m.rmse, 0.02);
  EXPECT_GE(s.ok_visible_frames, 150);
}

}  // namespace
}  // namespace sitepose::experiments
