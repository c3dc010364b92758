#include "sitepose/map/map_data.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace sitepose::map {
namespace {

KeyFrame make_keyframe(int n_keypoints, double x_m) {
  KeyFrame kf;
  kf.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x_m, 0, 0));
  for (int i = 0; i < n_keypoints; ++i) {
    KeyPointData kp;
    kp.uv_px = Eigen::Vector2d(10.0 * i, 20.0);
    kp.descriptor.fill(static_cast<std::uint8_t>(i));
    kf.keypoints.push_back(kp);
  }
  return kf;
}

// Three keyframes sharing `shared` points pairwise in a chain 0-1-2.
struct ChainMap {
  MapData map;
  KeyFrameId kf[3];
  std::vector<PointId> points;
  explicit ChainMap(int shared) {
    kf[0] = map.add_keyframe(make_keyframe(2 * shared, 0.0));
    for (int i = 0; i < 2 * shared; ++i) points.push_back(map.add_point({0.1 * i, 0, 5}, kf[0], i));
    KeyFrame k1 = make_keyframe(2 * shared, 1.0);
    for (int i = 0; i < shared; ++i) k1.point_of_keypoint.push_back(points[i]);
    kf[1] = map.add_keyframe(std::move(k1));
    for (int i = shared; i < 2 * shared; ++i) map.add_point({0.1 * i, 1, 5}, kf[1], i);
    KeyFrame k2 = make_keyframe(2 * shared, 2.0);
    for (int i = 0; i < shared; ++i) k2.point_of_keypoint.push_back(points[i]);
    kf[2] = map.add_keyframe(std::move(k2));
  }
};

TEST(MapData, ObservationsAreConsistentBothWays) {
  ChainMap m(20);
  for (const auto& [pid, p] : m.map.points()) {
    for (const auto& [kf_id, index] : p.observations) {
      EXPECT_EQ(m.map.keyframe(kf_id)->point_of_keypoint[index], pid);
    }
  }
  EXPECT_EQ(m.map.point(m.points[0])->observations.size(), 3u);
}

TEST(MapData, CovisibilityAndSpanningTree) {
  ChainMap m(20);
  EXPECT_EQ(m.map.keyframe(m.kf[1])->covisibility.at(m.kf[0]), 20);
  EXPECT_EQ(m.map.keyframe(m.kf[2])->covisibility.at(m.kf[0]), 20);
  EXPECT_EQ(m.map.keyframe(m.kf[1])->parent, m.kf[0]);
  const auto best = m.map.best_covisible(m.kf[0], 5);
  EXPECT_EQ(best.size(), 2u);
}

TEST(MapData, RemovingAKeyframeKeepsTheMapConsistent) {
  ChainMap m(20);
  m.map.set_keyframe_bad(m.kf[1]);
  EXPECT_EQ(m.map.keyframe(m.kf[1]), nullptr);
  EXPECT_EQ(m.map.keyframe(m.kf[0])->covisibility.count(m.kf[1]), 0u);
  // Points seen by keyframes 0 and 2 survive with two observations.
  EXPECT_EQ(m.map.good_point(m.points[0])->observations.size(), 2u);
  for (const auto& [pid, p] : m.map.points()) {
    if (p.bad) {
      EXPECT_TRUE(p.observations.empty());
      continue;
    }
    for (const auto& [kf_id, index] : p.observations) EXPECT_NE(kf_id, m.kf[1]);
  }
  // The first keyframe anchors the gauge and is never removed.
  m.map.set_keyframe_bad(m.kf[0]);
  EXPECT_NE(m.map.keyframe(m.kf[0]), nullptr);
}

// ChainMap and a provisional map after it: keyframes 3 and 4, sharing the
// points keyframe 3 made, nothing with the chain.
struct ChainWithProvisionalMap : ChainMap {
  KeyFrameId first_provisional = kNoKeyFrame;
  std::vector<PointId> provisional_points;
  ChainWithProvisionalMap() : ChainMap(20) {
    first_provisional = map.add_keyframe(make_keyframe(20, 30.0));
    map.set_provisional_since(first_provisional);
    for (int i = 0; i < 20; ++i)
      provisional_points.push_back(map.add_point({30.0 + 0.1 * i, 0, 5}, first_provisional, i));
    KeyFrame next = make_keyframe(20, 31.0);
    for (PointId id : provisional_points) next.point_of_keypoint.push_back(id);
    map.add_keyframe(std::move(next));
  }
};

TEST(MapData, MovingAProvisionalMapMovesItsKeyFramesAndPointsOnly) {
  ChainWithProvisionalMap m;
  const SE3 correction(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())),
                       Eigen::Vector3d(-25.0, 1.0, 0.5));
  const MapData before = m.map;
  m.map.move_keyframes_from(m.first_provisional, correction);
  for (const auto& [id, kf] : m.map.keyframes()) {
    const SE3 expected = id >= m.first_provisional ? correction * before.keyframe(id)->T_world_cam
                                                   : before.keyframe(id)->T_world_cam;
    EXPECT_TRUE(kf.T_world_cam.matrix().isApprox(expected.matrix(), 1e-12)) << "keyframe " << id;
  }
  for (const auto& [id, p] : m.map.points()) {
    const MapPoint& old = *before.point(id);
    const bool provisional = p.first_keyframe >= m.first_provisional;
    EXPECT_TRUE(p.p_world.isApprox(provisional ? correction * old.p_world : old.p_world, 1e-12)) << id;
    EXPECT_TRUE(
        p.normal.isApprox(provisional ? correction.rotation_matrix() * old.normal : old.normal, 1e-12));
  }
  EXPECT_EQ(m.map.provisional_since(), m.first_provisional) << "moving is not joining";
}

// The published drift term's distance (PoseEstimate::map_travel_m) after a
// join: from the place where the provisional map met the site map.
TEST(MapData, AJoinedProvisionalMapTakesItsMapTravelFromThePlaceOfTheJoin) {
  ChainWithProvisionalMap m;  // provisional keyframes at x = 30 and 31
  m.map.keyframe(m.kf[2])->map_travel_m = 9.0;
  m.map.set_map_travel_from(m.first_provisional, Eigen::Vector3d(31.0, 0.0, 0.0), 2.5);
  EXPECT_DOUBLE_EQ(m.map.keyframe(m.first_provisional)->map_travel_m, 3.5);
  EXPECT_DOUBLE_EQ(m.map.keyframe(m.first_provisional + 1)->map_travel_m, 2.5);
  EXPECT_EQ(m.map.keyframe(m.kf[2])->map_travel_m, 9.0) << "a site-map keyframe changed";
}

// The least of (map travel + distance) over the keyframe sharing most of
// the matches and those sharing enough close ones.
TEST(MapData, MapTravelIsTheLeastOverTheKeyFramesThatHoldTheCamera) {
  ChainMap m(20);  // keyframes at x = 0, 1, 2
  m.map.keyframe(m.kf[0])->map_travel_m = 1.0;
  m.map.keyframe(m.kf[1])->map_travel_m = 7.0;
  m.map.keyframe(m.kf[2])->map_travel_m = 2.0;
  const Eigen::Vector3d camera_m(1.0, 3.0, 4.0);  // 5 m from keyframe 1
  const std::map<KeyFrameId, int> sharing = {{m.kf[0], 3}, {m.kf[1], 40}, {m.kf[2], 5}};
  // Keyframe 1 shares most: its 7 m + 5 m.
  EXPECT_EQ(map_travel_at(m.map, sharing, {}, camera_m), 12.0);
  // Keyframe 2 also holds enough of the close matches: 2 m + sqrt(26) m.
  EXPECT_EQ(map_travel_at(m.map, sharing, {{m.kf[2], kCovisibilityThreshold}}, camera_m),
            2.0 + std::sqrt(26.0));
  // Too few close matches of keyframe 0 do not tie the camera to it.
  EXPECT_EQ(map_travel_at(m.map, sharing, {{m.kf[0], kCovisibilityThreshold - 1}}, camera_m), 12.0);
  EXPECT_EQ(map_travel_at(m.map, {}, {}, camera_m), std::nullopt);
}

// For a map file saved without the distances.
TEST(MapData, MapTravelAlongTheSpanningTreeEndsAtItsRootAndCutsACycle) {
  ChainMap m(20);
  ASSERT_EQ(m.map.keyframe(m.kf[1])->parent, m.kf[0]);
  ASSERT_EQ(m.map.keyframe(m.kf[2])->parent, m.kf[0]);  // ties go to the lower id
  m.map.keyframe(m.kf[0])->map_travel_m = 5.0;
  m.map.set_map_travel_along_spanning_tree();
  EXPECT_EQ(m.map.keyframe(m.kf[0])->map_travel_m, 0.0);
  EXPECT_EQ(m.map.keyframe(m.kf[1])->map_travel_m, 1.0);
  EXPECT_EQ(m.map.keyframe(m.kf[2])->map_travel_m, 2.0);
  // A corrupt file's parent cycle 0 -> 1 -> 0: each keyframe still gets a
  // finite distance, and the walk ends.
  m.map.keyframe(m.kf[0])->parent = m.kf[1];
  m.map.set_map_travel_along_spanning_tree();
  for (const auto& [id, kf] : m.map.keyframes()) {
    EXPECT_TRUE(std::isfinite(kf.map_travel_m)) << id;
    EXPECT_LE(kf.map_travel_m, 3.0) << id;
  }
}

TEST(MapData, DroppingAProvisionalMapLeavesTheSiteMapAsItWas) {
  ChainWithProvisionalMap m;
  const std::vector<KeyFrameId> dropped = m.map.drop_keyframes_from(m.first_provisional);
  EXPECT_EQ(dropped, (std::vector<KeyFrameId>{m.first_provisional + 1, m.first_provisional}));
  EXPECT_EQ(m.map.keyframe_count(), 3u);
  EXPECT_EQ(m.map.last_keyframe(), m.kf[2]);
  EXPECT_EQ(m.map.provisional_since(), kNoKeyFrame);
  for (PointId id : m.provisional_points) EXPECT_EQ(m.map.good_point(id), nullptr) << id;
  EXPECT_EQ(m.map.good_point(m.points[0])->observations.size(), 3u);
  // The next keyframe gets a fresh id, never a dropped one.
  EXPECT_GT(m.map.add_keyframe(make_keyframe(1, 3.0)), m.first_provisional + 1);
}

TEST(MapData, DroppingAJoinedMapNotYetConfirmedClearsItsMark) {
  ChainWithProvisionalMap m;
  m.map.set_provisional_since(kNoKeyFrame);  // joined
  m.map.set_joined_unconfirmed_since(m.first_provisional);
  m.map.drop_keyframes_from(m.first_provisional);
  EXPECT_EQ(m.map.joined_unconfirmed_since(), kNoKeyFrame);
  EXPECT_EQ(m.map.keyframe_count(), 3u);
}

SE3 turned_pose(double angle_rad, const Eigen::Vector3d& t_m) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY())), t_m);
}

void expect_same_pose(const std::optional<SE3>& got, const SE3& expected) {
  ASSERT_TRUE(got.has_value());
  EXPECT_LT((got->matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-12)
      << got->matrix() << "\nexpected\n"
      << expected.matrix();
}

// ChainMap with a keyframe 3 hanging from keyframe 1 (it shares only the
// points keyframe 1 made); poses turned so that compositions in the wrong
// order show.
struct ChainWithBranch : ChainMap {
  KeyFrameId branch = kNoKeyFrame;
  ChainWithBranch() : ChainMap(20) {
    map.keep_removed_keyframe_links(true);
    KeyFrame k3 = make_keyframe(40, 3.0);
    for (int i = 0; i < 20; ++i)
      k3.point_of_keypoint.push_back(map.keyframe(kf[1])->point_of_keypoint[20 + i]);
    branch = map.add_keyframe(std::move(k3));
    map.keyframe(kf[1])->T_world_cam = turned_pose(0.3, {1.0, 0.2, -0.1});
    map.keyframe(branch)->T_world_cam = turned_pose(-0.2, {3.0, 0.1, 0.4});
  }
};

TEST(MapData, ARemovedKeyFrameIsPlacedThroughTheParentsItHungFrom) {
  ChainWithBranch m;
  ASSERT_EQ(m.map.keyframe(m.branch)->parent, m.kf[1]);
  ASSERT_EQ(m.map.keyframe(m.kf[1])->parent, m.kf[0]);
  const SE3 T_world_branch = m.map.keyframe(m.branch)->T_world_cam;
  const SE3 T_world_1 = m.map.keyframe(m.kf[1])->T_world_cam;
  m.map.set_keyframe_bad(m.branch);
  m.map.set_keyframe_bad(m.kf[1]);
  ASSERT_EQ(m.map.keyframe(m.branch), nullptr);
  ASSERT_EQ(m.map.keyframe(m.kf[1]), nullptr);
  expect_same_pose(m.map.T_world_keyframe(m.branch), T_world_branch);
  expect_same_pose(m.map.T_world_keyframe(m.kf[1]), T_world_1);
  expect_same_pose(m.map.T_world_keyframe(m.kf[2]), m.map.keyframe(m.kf[2])->T_world_cam);
  // A correction of the map after the removals (a loop closed) moves the
  // removed keyframes with the keyframe they hang from.
  const SE3 correction = turned_pose(0.1, {0.5, -0.3, 0.2});
  m.map.keyframe(m.kf[0])->T_world_cam = correction * m.map.keyframe(m.kf[0])->T_world_cam;
  expect_same_pose(m.map.T_world_keyframe(m.branch), correction * T_world_branch);
  expect_same_pose(m.map.T_world_keyframe(m.kf[1]), correction * T_world_1);
  EXPECT_FALSE(m.map.T_world_keyframe(m.branch + 100).has_value());
}

TEST(MapData, RemovedKeyFramesLeaveNoLinkUnlessAsked) {
  ChainMap m(20);
  m.map.set_keyframe_bad(m.kf[1]);
  EXPECT_FALSE(m.map.T_world_keyframe(m.kf[1]).has_value());
  expect_same_pose(m.map.T_world_keyframe(m.kf[0]), m.map.keyframe(m.kf[0])->T_world_cam);
}

TEST(MapData, KeyFramesDroppedWithAProvisionalMapCannotBePlaced) {
  ChainWithProvisionalMap m;
  m.map.keep_removed_keyframe_links(true);
  const KeyFrameId second = m.first_provisional + 1;
  m.map.set_keyframe_bad(second);  // culled while the provisional map was tracked
  ASSERT_TRUE(m.map.T_world_keyframe(second).has_value());
  m.map.set_keyframe_bad(m.kf[1]);
  m.map.drop_keyframes_from(m.first_provisional);
  EXPECT_FALSE(m.map.T_world_keyframe(second).has_value());
  EXPECT_FALSE(m.map.T_world_keyframe(m.first_provisional).has_value());
  EXPECT_TRUE(m.map.T_world_keyframe(m.kf[1]).has_value()) << "a site-map keyframe's link was dropped";
}

TEST(MapData, ReplacePointMovesObservations) {
  ChainMap m(20);
  const PointId a = m.points[0];
  const PointId b = m.points[25];  // seen by keyframe 0 only
  m.map.replace_point(b, a);
  EXPECT_TRUE(m.map.point(b)->bad);
  EXPECT_EQ(m.map.keyframe(m.kf[0])->point_of_keypoint[25], kNoPoint);  // kf 0 already saw a
  EXPECT_EQ(m.map.purge_bad_points(), 1u);
  EXPECT_EQ(m.map.point(b), nullptr);
}

TEST(MapData, ScaleRangeFromReferenceView) {
  MapData map(ScalePyramid{1.2, 8});
  KeyFrame kf = make_keyframe(1, 0.0);
  kf.keypoints[0].octave = 2;
  const KeyFrameId id = map.add_keyframe(std::move(kf));
  const PointId pid = map.add_point({0, 0, 10}, id, 0);
  const MapPoint* p = map.point(pid);
  EXPECT_NEAR(p->max_distance_m, 10.0 * 1.44, 1e-9);
  EXPECT_NEAR(p->min_distance_m, p->max_distance_m / std::pow(1.2, 7), 1e-9);
  EXPECT_EQ(map.pyramid().predict_level(10.0, p->max_distance_m), 2);
  EXPECT_LT((p->normal - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

TEST(MapData, AddKeyframeKeepsOneKeypointPerPoint) {
  MapData map;
  const KeyFrameId k0 = map.add_keyframe(make_keyframe(3, 0.0));
  const PointId pid = map.add_point({0, 0, 5}, k0, 0);
  map.add_point({1, 0, 5}, k0, 1);
  KeyFrame k1 = make_keyframe(3, 1.0);
  k1.point_of_keypoint = {pid, pid, 12345};  // a duplicate and a missing point
  const KeyFrameId id1 = map.add_keyframe(std::move(k1));
  const KeyFrame* kf = map.keyframe(id1);
  EXPECT_EQ(kf->point_of_keypoint[0], pid);
  EXPECT_EQ(kf->point_of_keypoint[1], kNoPoint);
  EXPECT_EQ(kf->point_of_keypoint[2], kNoPoint);
  EXPECT_EQ(map.point(pid)->observations.at(id1), 0);
}

TEST(MapData, ObservationWeightCountsStereoTwice) {
  MapData map;
  KeyFrame k0 = make_keyframe(2, 0.0);
  k0.keypoints[0].u_right_px = 100.0;  // stereo
  const KeyFrameId id0 = map.add_keyframe(std::move(k0));
  const PointId pid = map.add_point({0, 0, 5}, id0, 0);
  EXPECT_EQ(map.observation_weight(pid), 2);
  KeyFrame k1 = make_keyframe(2, 1.0);  // monocular keypoints
  k1.point_of_keypoint = {kNoPoint, pid};
  map.add_keyframe(std::move(k1));
  EXPECT_EQ(map.observation_weight(pid), 3);
  map.set_point_bad(pid);
  EXPECT_EQ(map.observation_weight(pid), 0);
  EXPECT_EQ(map.observation_weight(98765), 0);
}

TEST(MapData, GeometryUpdateFollowsAMovedPointAndKeepsTheDescriptor) {
  MapData map(ScalePyramid{1.2, 8});
  KeyFrame kf = make_keyframe(1, 0.0);
  kf.keypoints[0].octave = 1;
  const KeyFrameId id = map.add_keyframe(std::move(kf));
  const PointId pid = map.add_point({0, 0, 10}, id, 0);
  const Descriptor descriptor = map.point(pid)->descriptor;
  map.point(pid)->p_world = {10, 0, 10};
  map.update_point_geometry(pid);
  const MapPoint* p = map.point(pid);
  EXPECT_NEAR(p->max_distance_m, std::sqrt(200.0) * 1.2, 1e-9);
  EXPECT_LT((p->normal - Eigen::Vector3d(1, 0, 1).normalized()).norm(), 1e-12);
  EXPECT_EQ(p->descriptor, descriptor);
}

// restore() (map files) refuses a map whose two sides disagree.
TEST(MapDataRestore, NamesTheFirstInconsistency) {
  const auto keyframe = [](KeyFrameId id, int keypoints, KeyFrameId parent) {
    KeyFrame kf;
    kf.id = id;
    kf.parent = parent;
    kf.keypoints.resize(keypoints);
    return kf;
  };
  const auto point = [](PointId id, std::map<KeyFrameId, int> observations) {
    MapPoint p;
    p.id = id;
    p.observations = std::move(observations);
    return p;
  };
  auto good = MapData::restore({}, {keyframe(0, 3, kNoKeyFrame), keyframe(4, 3, 0)},
                               {point(7, {{0, 1}, {4, 2}})}, 0, 4);
  ASSERT_TRUE(good) << good.error().message;
  EXPECT_EQ(good->keyframe(4)->point_of_keypoint, (std::vector<PointId>{kNoPoint, kNoPoint, 7}));
  EXPECT_EQ(good->keyframe(0)->children, (std::set<KeyFrameId>{4}));

  const auto why = [](Expected<MapData> restored) {
    return restored ? std::string("accepted") : restored.error().message;
  };
  EXPECT_NE(why(MapData::restore({}, {keyframe(0, 3, kNoKeyFrame)}, {point(7, {{0, 1}, {9, 0}})}, 0, 0))
                .find("keyframe 9, not in the map"),
            std::string::npos);
  EXPECT_NE(why(MapData::restore({}, {keyframe(0, 3, kNoKeyFrame)}, {point(7, {{0, 3}})}, 0, 0))
                .find("names keypoint 3"),
            std::string::npos);
  EXPECT_NE(
      why(MapData::restore({}, {keyframe(0, 3, kNoKeyFrame)}, {point(7, {{0, 1}}), point(8, {{0, 1}})}, 0, 0))
          .find("is claimed by points"),
      std::string::npos);
  EXPECT_NE(why(MapData::restore({}, {keyframe(0, 3, 5)}, {}, 0, 0)).find("parent keyframe 5"),
            std::string::npos);
  EXPECT_NE(
      why(MapData::restore({}, {keyframe(0, 3, kNoKeyFrame)}, {}, 0, 2)).find("keyframe 2 is not in the map"),
      std::string::npos);
  KeyFrame one_sided = keyframe(4, 3, 0);
  one_sided.loop_edges = {0};
  EXPECT_NE(why(MapData::restore({}, {keyframe(0, 3, kNoKeyFrame), one_sided}, {}, 0, 4))
                .find("keyframe 4 has a loop edge to keyframe 0"),
            std::string::npos);
  KeyFrame looped_back = keyframe(0, 3, kNoKeyFrame);
  looped_back.loop_edges = {4};
  EXPECT_EQ(why(MapData::restore({}, {looped_back, one_sided}, {}, 0, 4)), "accepted");
}

// A loop edge is kept on both keyframes and keeps its keyframes from being
// removed (the loop's constraint would go with them).
TEST(MapData, LoopEdgesAreMutualAndKeepTheirKeyFrames) {
  MapData map;
  const KeyFrameId a = map.add_keyframe(make_keyframe(2, 0.0));
  const KeyFrameId b = map.add_keyframe(make_keyframe(2, 1.0));
  const KeyFrameId c = map.add_keyframe(make_keyframe(2, 2.0));
  const KeyFrameId d = map.add_keyframe(make_keyframe(2, 3.0));
  EXPECT_FALSE(map.add_loop_edge(b, b));
  EXPECT_FALSE(map.add_loop_edge(b, 99));
  ASSERT_TRUE(map.add_loop_edge(b, c));
  EXPECT_EQ(map.keyframe(b)->loop_edges, (std::set<KeyFrameId>{c}));
  EXPECT_EQ(map.keyframe(c)->loop_edges, (std::set<KeyFrameId>{b}));
  map.set_keyframe_bad(c);
  EXPECT_NE(map.keyframe(c), nullptr) << "a keyframe with a loop edge was removed";
  map.set_keyframe_bad(d);
  EXPECT_EQ(map.keyframe(d), nullptr);
  EXPECT_NE(map.keyframe(a), nullptr);
}

}  // namespace
}  // namespace sitepose::map
