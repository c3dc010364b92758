#pragma once
// A map built the way the tracker builds one (testing::SimTracker): a
// drive along x with keyframes every 0.5 m, one keyframe culled and one
// point set bad, so the file sees the holes a real map has.

#include "sitepose/map/shared_map.hpp"
#include "sitepose/testing/map_world.hpp"

namespace sitepose::mapfile::test {

inline void build_map(map::SharedMap& shared, int keyframes, int points_per_plane = 200) {
  const testing::World world = testing::make_world(points_per_plane, 11);
  testing::SimTracker tracker(world, testing::test_camera(), shared, {});
  for (int k = 0; k < keyframes; ++k) {
    const SE3 pose = testing::pose_at_x(0.5 * k);
    tracker.insert_keyframe(pose, pose);
  }
  shared.write([keyframes](map::MapData& m) {
    if (m.keyframe_count() > 3) m.set_keyframe_bad(2);
    for (const auto& [id, p] : m.points()) {
      if (!p.bad) {
        m.set_point_bad(id);
        break;
      }
    }
    // Fields the simulated tracker leaves at their defaults.
    for (map::KeyFrameId id = 0; id < keyframes; ++id) {
      map::KeyFrame* kf = m.keyframe(id);
      if (kf == nullptr) continue;
      kf->frame_seq = 3 * id;
      kf->t_ns = 100'000'000 * id + 7;
      // Not the straight 0.5 m a keyframe the spanning tree would give, so a
      // test sees whether the file's value or a derived one was read.
      kf->map_travel_m = 0.75 * id + 0.125;
      if (!kf->keypoints.empty()) kf->keypoints.front().instance = 5;
    }
  });
}

}  // namespace sitepose::mapfile::test
