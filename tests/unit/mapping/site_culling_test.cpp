#include "sitepose/mapping/site_culling.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sitepose/testing/map_world.hpp"

namespace sitepose::mapping {
namespace {

using testing::pose_at_x;

constexpr double kRadPerDeg = std::numbers::pi / 180.0;

map::KeyFrame keyframe_at(double x_m, double yaw_deg = 0.0) {
  map::KeyFrame kf;
  kf.T_world_cam = pose_at_x(x_m, yaw_deg * kRadPerDeg);
  return kf;
}

// Keyframes without points (no covisibility between them) at these places.
map::MapData map_with_keyframes(const std::vector<std::pair<double, double>>& x_m_yaw_deg) {
  map::MapData map;
  for (const auto& [x, yaw] : x_m_yaw_deg) map.add_keyframe(keyframe_at(x, yaw));
  return map;
}

TEST(SiteCulling, NeighbourhoodIsDistanceAndViewingAngle) {
  const SiteNeighbourhood site{1.0, 15.0};
  const map::KeyFrame a = keyframe_at(0.0);
  EXPECT_TRUE(within_neighbourhood(a, keyframe_at(0.9), site));
  EXPECT_FALSE(within_neighbourhood(a, keyframe_at(1.1), site));
  EXPECT_TRUE(within_neighbourhood(a, keyframe_at(0.5, 14.0), site));
  EXPECT_FALSE(within_neighbourhood(a, keyframe_at(0.5, 16.0), site));
  // Driving the other way along the strip looks at the other side.
  EXPECT_FALSE(within_neighbourhood(a, keyframe_at(0.0, 180.0), site));
}

TEST(SiteCulling, CellsAreCentredOnTheFirstKeyframe) {
  const SiteNeighbourhood site{1.0, 15.0};
  const SiteCell origin = site_cell_of(keyframe_at(0.0), site);
  EXPECT_EQ(site_cell_of(keyframe_at(-0.001, -0.1), site), origin);
  EXPECT_EQ(site_cell_of(keyframe_at(0.49, 7.0), site), origin);
  EXPECT_NE(site_cell_of(keyframe_at(0.51), site), origin);
  EXPECT_NE(site_cell_of(keyframe_at(0.0, 8.0), site), origin);
}

TEST(SiteCulling, CandidatesComeFromTheWholeMapNewestFirst) {
  // 0: first, 1-3 near x = 5, 4 far, 5 near but turned, 6 the current one, 7 queued.
  map::MapData map = map_with_keyframes(
      {{0.0, 0.0}, {5.2, 0.0}, {4.5, 5.0}, {5.9, 0.0}, {9.0, 0.0}, {5.0, 90.0}, {5.0, 0.0}, {5.1, 0.0}});
  const SiteNeighbourhood site{1.0, 15.0};
  EXPECT_EQ(site_candidates(map, 6, site), (std::vector<map::KeyFrameId>{3, 2, 1}));
  map.set_tracker_keyframes({2});
  EXPECT_EQ(site_candidates(map, 6, site), (std::vector<map::KeyFrameId>{3, 1}));
  // The first keyframe is never a candidate.
  EXPECT_TRUE(site_candidates(map_with_keyframes({{0.0, 0.0}, {0.1, 0.0}}), 1, site).empty());
}

TEST(SiteCulling, AKeyframeAloneInItsCellStays) {
  const map::MapData map = map_with_keyframes({{0.0, 0.0}, {3.0, 0.0}, {3.2, 0.0}, {4.0, 0.0}});
  const SiteNeighbourhood site{1.0, 15.0};
  EXPECT_TRUE(has_cell_mate(map, 1, site));
  EXPECT_TRUE(has_cell_mate(map, 2, site));
  EXPECT_FALSE(has_cell_mate(map, 3, site));
  // Without points nothing is redundant: nothing may go.
  EXPECT_FALSE(may_cull_from_site(map, 1, 3, site, 0.9, 40.0));
}

}  // namespace
}  // namespace sitepose::mapping
