// Articulated machines (an excavator that slews and digs in place, a wheel
// loader) and people on foot: per-part truth, the part mask, and the
// object-level moving flag when only a part moves.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "sitepose/sim/simulator.hpp"
#include "sitepose/testing/simulated.hpp"

namespace sitepose::sim {
namespace {

// The excavator's tracks stand all along; its house slews during 0.5-2.5 s
// only. The loader digs during 1-2 s. A person walks, one crouches.
Scenario working_scenario() {
  auto s = parse_scenario(R"(name: unit-articulated
description: "unit test"
fps: 6
duration_s: 3.5
seed: 3
machines:
  - class: excavator
    x_m: 1
    y_m: -10
    work: [{at_s: 0.5, duration_s: 2, slew_deg: 40, period_s: 4}]
  - class: loader
    x_m: 8
    y_m: -9
    yaw_deg: 90
    work: [{at_s: 1, duration_s: 1, dig_deg: 20, period_s: 2}]
  - class: person
    waypoints: [[-4, -5], [4, -5]]
    speed_mps: 1.2
  - {class: person, pose: crouching, x_m: 3, y_m: -5.5}
)",
                          "unit-articulated.yaml");
  SITEPOSE_CHECK(s.has_value());
  return *s;
}

struct WorkingSite {
  static Scenario scenario() { return working_scenario(); }
  static SimOptions options() {
    SimOptions o;
    o.width = 320;
    o.height = 180;
    return o;
  }
};
using ArticulatedTest = testing::RenderedScenarioTest<WorkingSite>;

TEST_F(ArticulatedTest, SlewingHouseMakesTheExcavatorMovingWhileItsTracksStand) {
  ASSERT_TRUE(sim_->has_articulated());
  int moving_frames = 0;
  for (const SimFrame& f : frames_) {
    const ObjectTruth& ex = f.objects[0];
    ASSERT_EQ(ex.parts.size(), 5u);
    EXPECT_EQ(ex.parts[0].name, "undercarriage");
    EXPECT_FALSE(ex.parts[0].moving);  // the tracks never move
    // The base pose never changes: the flag comes from the parts alone.
    EXPECT_EQ(ex.T_site_obj.translation(), frames_[0].objects[0].T_site_obj.translation());
    // Frame k moves when its pose differs from frame k-1's: frames 4 (t =
    // 0.67 s) to 15 (t = 2.5 s, the last of the stroke).
    const bool slewing = f.index >= 4 && f.index <= 15;
    bool any_part = false;
    for (const PartTruth& p : ex.parts) any_part = any_part || p.moving;
    EXPECT_EQ(ex.moving, any_part) << "frame " << f.index;
    EXPECT_EQ(ex.parts[1].moving, slewing) << "frame " << f.index;
    moving_frames += ex.moving ? 1 : 0;
  }
  EXPECT_EQ(moving_frames, 12);
}

TEST_F(ArticulatedTest, PartMaskAgreesWithTheInstanceMaskAndThePartBoxes) {
  for (const SimFrame& f : frames_) {
    ASSERT_EQ(f.part_mask.type(), CV_8UC1);
    for (const ObjectTruth& o : f.objects) {
      int part_pixels = 0;
      for (const PartTruth& p : o.parts) {
        const cv::Mat mine = (f.instance_mask == o.instance) & (f.part_mask == p.part);
        EXPECT_EQ(cv::countNonZero(mine), p.pixels);
        if (p.visible) {
          EXPECT_EQ(cv::boundingRect(mine), p.box);
        }
        part_pixels += p.pixels;
      }
      if (!o.parts.empty()) {
        EXPECT_EQ(part_pixels, o.pixels) << "every pixel of a machine is on a part";
      }
    }
  }
  // The house of the excavator is in view.
  EXPECT_GT(frames_[6].objects[0].parts[1].pixels, 100);
}

TEST_F(ArticulatedTest, LoaderMovesOnlyWhileItDigsAndPeopleAreObjects) {
  for (const SimFrame& f : frames_) {
    const ObjectTruth& loader = f.objects[1];
    EXPECT_EQ(loader.class_name, "loader");
    ASSERT_EQ(loader.parts.size(), 3u);
    const bool digging = f.index >= 7 && f.index <= 12;  // 1.17 s .. 2 s
    EXPECT_EQ(loader.moving, digging) << "frame " << f.index;
    EXPECT_FALSE(loader.parts[0].moving);
    EXPECT_EQ(f.objects[2].class_name, "person");
    EXPECT_TRUE(f.objects[2].parts.empty());
    EXPECT_FALSE(f.objects[3].moving);
  }
  EXPECT_TRUE(frames_[10].objects[2].moving);  // walking
  EXPECT_GT(frames_[10].objects[2].pixels, 50);
  EXPECT_GT(frames_[10].objects[3].pixels, 20);
}

TEST(Articulated, ScenarioWithoutWorkHasNoPartMask) {
  auto s = parse_scenario(
      "name: u\ndescription: \"u\"\nduration_s: 0.5\nmachines:\n"
      "  - {class: excavator, x_m: 1, y_m: -9}\n",
      "u.yaml");
  ASSERT_TRUE(s) << s.error().message;
  SimOptions o;
  o.width = 160;
  o.height = 90;
  auto sim = Simulator::create(*s, o);
  ASSERT_TRUE(sim);
  EXPECT_FALSE(sim->has_articulated());
  const SimFrame f = sim->render(0);
  EXPECT_TRUE(f.part_mask.empty());
  EXPECT_TRUE(f.objects[0].parts.empty());
}

TEST(Articulated, WorkOnlyForParkedExcavatorsAndLoaders) {
  const auto bad = parse_scenario(R"(name: u
description: "u"
duration_s: 1
machines:
  - class: truck
    x_m: 1
    y_m: -9
    work: [{at_s: 0, duration_s: 1, dig_deg: 10}]
  - class: roller
    pose: crouching
)",
                                  "u.yaml");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("only an excavator or a loader"), std::string::npos)
      << bad.error().message;
  EXPECT_NE(bad.error().message.find("only a person has a pose"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace sitepose::sim
