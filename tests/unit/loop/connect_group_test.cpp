// connect_group sets what count_group_connections counted under the read
// lock, and counts again when the tracker inserted a keyframe in between:
// either way the group ends as if it had been counted under the write lock
// (MapData::update_connections / update_point_appearance).

#include <gtest/gtest.h>

#include "sitepose/experiments/synthetic_loop.hpp"
#include "sitepose/loop/loop_correction.hpp"
#include "sitepose/testing/cameras.hpp"

namespace sitepose::loop {
namespace {

StereoCamera test_camera() { return testing::centred_camera(640, 360, 500.0, 0.5); }

struct Lane {
  map::MapData map;
  experiments::TexturedWall wall;
  std::vector<map::PointId> point_of_wall_point;
  std::vector<map::KeyFrameId> keyframes;
};

map::KeyFrameId insert_at(Lane& lane, double x_m) {
  const SE3 T = experiments::lane_camera_at(x_m);
  return experiments::insert_wall_keyframe(lane.map, test_camera(), lane.wall, T, T,
                                           lane.point_of_wall_point);
}

// Keyframes at 0 .. 9 m with exact poses, sharing the wall's points.
Lane make_lane() {
  Lane lane;
  lane.wall = experiments::make_textured_wall(5, 12.0, 1500);
  lane.point_of_wall_point.assign(lane.wall.p_world_m.size(), map::kNoPoint);
  for (int k = 0; k < 10; ++k) lane.keyframes.push_back(insert_at(lane, k));
  for (const auto& [pid, p] : lane.map.points()) lane.map.update_point_appearance(pid);
  for (map::KeyFrameId id : lane.keyframes) lane.map.update_connections(id);
  return lane;
}

// The group: keyframes 3 .. 6 (unmoved); the points with new views: those
// keyframe 5 observes.
struct Group {
  GroupCorrection plan;
  GroupApplied applied;
};

Group group_of(const Lane& lane) {
  Group g;
  for (int k = 3; k <= 6; ++k) {
    g.plan.T_world_cam[lane.keyframes[k]] = lane.map.keyframe(lane.keyframes[k])->T_world_cam;
  }
  for (map::PointId pid : lane.map.keyframe(lane.keyframes[5])->point_of_keypoint) {
    if (pid != map::kNoPoint) g.applied.points_with_new_views.insert(pid);
  }
  return g;
}

void expect_counted_under_the_write_lock(const map::MapData& got, map::MapData reference, const Group& g) {
  for (map::PointId pid : g.applied.points_with_new_views) reference.update_point_appearance(pid);
  for (const auto& [id, T] : g.plan.T_world_cam) reference.update_connections(id);
  for (const auto& [id, kf] : reference.keyframes()) {
    EXPECT_EQ(got.keyframe(id)->covisibility, kf.covisibility) << "keyframe " << id;
  }
  for (map::PointId pid : g.applied.points_with_new_views) {
    EXPECT_EQ(got.point(pid)->descriptor, reference.point(pid)->descriptor) << "point " << pid;
  }
}

TEST(ConnectGroup, SetsWhatWasCounted) {
  Lane lane = make_lane();
  Group g = group_of(lane);
  // The points' views change as a fusion would change them: keyframe 5's
  // points gain the view of a new keyframe at 5.5 m, counted under read.
  insert_at(lane, 5.5);
  const map::MapData reference = lane.map;
  const GroupConnections counted = count_group_connections(lane.map, g.plan, g.applied);
  connect_group(lane.map, {}, g.plan, counted, g.applied);
  expect_counted_under_the_write_lock(lane.map, reference, g);
}

TEST(ConnectGroup, CountsAgainWhenTheTrackerInsertedAKeyFrameSinceTheCount) {
  Lane lane = make_lane();
  Group g = group_of(lane);
  const GroupConnections counted = count_group_connections(lane.map, g.plan, g.applied);
  // Between the read and the write lock the tracker inserts a keyframe
  // that sees the group's points: the counts are stale.
  const map::KeyFrameId inserted = insert_at(lane, 4.5);
  const map::MapData reference = lane.map;
  connect_group(lane.map, {}, g.plan, counted, g.applied);
  expect_counted_under_the_write_lock(lane.map, reference, g);
  EXPECT_EQ(lane.map.keyframe(lane.keyframes[4])->covisibility.count(inserted), 1U);
}

}  // namespace
}  // namespace sitepose::loop
