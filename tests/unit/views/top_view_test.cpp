// `sitepose top`'s monitor on an in-process LCM bus (memq://): what a
// publisher sends is what the screen shows.

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include "sitepose/views/top_view.hpp"

namespace sitepose::views {
namespace {

TEST(TopMonitor, ShowsThePublishedHealthAndPose) {
  auto bus = std::make_shared<lcm::LCM>("memq://");
  ASSERT_TRUE(bus->good());
  auto monitor = TopMonitor::create(bus, "POSE", "HEALTH");
  ASSERT_TRUE(monitor) << monitor.error().message;
  EXPECT_NE(render_top((*monitor)->state(), TopClock::now(), false).find("no health_t received yet"),
            std::string::npos);

  sitepose::health_t health{};
  health.fps = 6.25F;
  health.state = sitepose::pose_t::STATE_LOST;
  health.state_reason = "no map";
  health.num_stages = 1;
  health.stage_names = {"detect"};
  health.drops = {42};
  health.queue_depths = {3};
  health.p50_ms = {12.0F};
  health.p99_ms = {30.0F};
  sitepose::pose_t pose{};
  pose.seq = 77;
  pose.frame = sitepose::pose_t::FRAME_SLAM;
  pose.position[0] = 1.5;
  pose.state = sitepose::pose_t::STATE_OK;
  pose.features_used = 99;
  ASSERT_EQ(bus->publish("HEALTH", &health), 0);
  ASSERT_EQ(bus->publish("POSE", &pose), 0);
  ASSERT_EQ(bus->publish("POSE", "junk", 4), 0);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE((*monitor)->handle(100));

  const TopState& state = (*monitor)->state();
  EXPECT_EQ(state.healths_received, 1);
  EXPECT_EQ(state.poses_received, 1);
  EXPECT_EQ(state.undecodable, 1);
  const std::string screen = render_top(state, TopClock::now(), false);
  for (const char* expected :
       {"rate 6.2 frames/s", "LOST", "detect", "42", "pose seq 77", "SLAM frame", "position 1.500",
        "inliers 99", "last error: POSE: a message that is not a pose_t"}) {
    EXPECT_NE(screen.find(expected), std::string::npos) << expected << "\n" << screen;
  }
  EXPECT_EQ(screen.find("\x1b["), std::string::npos) << "colour off";
  EXPECT_NE(render_top(state, TopClock::now(), true).find("\x1b[31mLOST"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::views
