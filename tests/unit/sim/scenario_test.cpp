#include "sitepose/sim/scenario.hpp"

#include <gtest/gtest.h>

#include <filesystem>

namespace sitepose::sim {
namespace {

const std::string kDir = std::string(SITEPOSE_SOURCE_DIR) + "/config/scenarios";

TEST(Scenario, EveryShippedScenarioLoads) {
  auto entries = list_scenarios(kDir);
  ASSERT_TRUE(entries) << entries.error().message;
  std::vector<std::string> names;
  for (const auto& e : *entries) {
    auto s = load_scenario(e.name, kDir);
    ASSERT_TRUE(s) << e.path << ": " << s.error().message;
    EXPECT_EQ(s->name, e.name) << "the name inside " << e.path << " must match the file name";
    EXPECT_FALSE(s->description.empty());
    EXPECT_GT(s->frame_count(), 0);
    names.push_back(e.name);
  }
  for (const char* required : {"static", "parked", "passing", "crowded", "stopgo", "parallel", "fast"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), required), names.end()) << required;
  }
}

TEST(Scenario, FastIsTenFpsAtFourKmhWithLowContrast) {
  auto s = load_scenario("fast", kDir);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->fps, 10.0);
  EXPECT_LT(s->realism.contrast, 1.0);
  double vmax = 0;
  for (const auto& seg : s->ego.segments) vmax = std::max(vmax, std::abs(seg.speed_mps));
  EXPECT_NEAR(vmax, 4.0 / 3.6, 0.01);
}

const char* kGood = R"(name: t
description: "test"
duration_s: 2
machines:
  - {class: truck, waypoints: [[0, -5], [10, -5]], speed_mps: 1.0}
)";

TEST(Scenario, MinimalTextParses) {
  auto s = parse_scenario(kGood, "t.yaml");
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_EQ(s->machines.size(), 1u);
  EXPECT_EQ(s->machines[0].waypoints.size(), 2u);
  EXPECT_EQ(s->frame_count(), 12);
}

void expect_error(const std::string& yaml, const std::vector<std::string>& fragments) {
  auto s = parse_scenario(yaml, "bad.yaml");
  ASSERT_FALSE(s) << yaml;
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument);
  for (const auto& f : fragments) {
    EXPECT_NE(s.error().message.find(f), std::string::npos) << "'" << f << "' not in: " << s.error().message;
  }
}

TEST(Scenario, BadFilesNameTheKeyValueAndExpectation) {
  expect_error("name: t\ndescription: d\nduration_s: 2\nego: {acel_mps2: 0.3}\n",
               {"bad.yaml:4", "ego.acel_mps2", "unknown key"});
  expect_error("name: t\ndescription: d\nduration_s: -1\n", {"duration_s", "-1", "must be > 0"});
  expect_error("name: t\nduration_s: 3\n", {"description"});
  expect_error("name: t\ndescription: d\nduration_s: 2\nmachines:\n  - {class: bulldozer}\n",
               {"machines[0].class", "bulldozer", "roller"});
  expect_error(
      "name: t\ndescription: d\nduration_s: 2\nmachines:\n  - {class: truck, waypoints: [[1, 2, 3], [4, "
      "5]]}\n",
      {"machines[0].waypoints", "[x, y]"});
  expect_error(
      "name: t\ndescription: d\nduration_s: 2\nego:\n  segments:\n    - {speed_mps: 9, duration_s: 1}\n",
      {"ego.segments[0].speed_mps", "9"});
  expect_error("name: t\ndescription: d\nduration_s: 2\ncamera: {side: up}\n", {"camera.side", "up"});
  expect_error("name: t\ndescription: d\nduration_s: 2\nego: {start_x_m: 1, waypoints: [[0, 0], [5, 0]]}\n",
               {"ego.waypoints", "not both"});
  expect_error("name: t\ndescription: d\nduration_s: 2\nego: {waypoints: [[0, 0], [0, 0]]}\n",
               {"ego.waypoints", "zero length"});
  expect_error("name: t\ndescription: d\nduration_s: 2\nego: {turn_radius_m: 3}\n",
               {"ego.turn_radius_m", "needs waypoints"});
  expect_error("name: t\ndescription: d\nduration_s: 2\nrealism: {motion_blur_samples: 2}\n",
               {"realism.motion_blur_samples", "must be odd"});
  expect_error(
      "name: t\ndescription: d\nduration_s: 2\nmachines:\n  - {class: truck, stops: [{at_s: 1, duration_s: "
      "2}]}\n",
      {"machines[0]", "need waypoints"});
  expect_error(
      "name: t\ndescription: d\nduration_s: 9\nrealism:\n  lens_covered:\n"
      "    - {at_s: 2, duration_s: 3}\n    - {at_s: 4, duration_s: 1}\n",
      {"realism.lens_covered[1].at_s", "time order"});
  expect_error(
      "name: t\ndescription: d\nduration_s: 9\nrealism: {lens_covered: [{at_s: 2, duration_s: 1, "
      "transmission: 2}]}\n",
      {"realism.lens_covered[0].transmission", "2"});
}

TEST(Scenario, BlackoutCoversTheLensForTenFramesWhileTheEgoDrives) {
  auto s = load_scenario("blackout", kDir);
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_EQ(s->realism.lens_covered.size(), 1u);
  const LensCoverSpec& c = s->realism.lens_covered[0];
  int covered = 0;
  for (int k = 0; k < s->frame_count(); ++k)
    covered += k / s->fps >= c.at_s && k / s->fps < c.at_s + c.duration_s;
  EXPECT_EQ(covered, 10);
  EXPECT_LT(c.transmission, 0.1);
  EXPECT_GT(s->ego.segments.at(0).speed_mps, 0.5);
}

TEST(Scenario, UnknownNameListsTheKnownOnes) {
  auto s = load_scenario("no_such_scenario", kDir);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_NE(s.error().message.find("crowded"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace sitepose::sim
