#include "sitepose/mapping/new_points.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "sitepose/mapping/fuse.hpp"
#include "sitepose/mapping/keyframe_culling.hpp"
#include "sitepose/testing/map_world.hpp"

namespace sitepose::mapping {
namespace {

using testing::make_world;
using testing::pose_at_x;
using testing::test_camera;

// A keyframe snapshot of monocular keypoints (no stereo, no points) and the
// world index of each keypoint.
struct MonoView {
  KeyFrameSnapshot snapshot;
  std::vector<int> world_of_keypoint;
};

MonoView mono_view(const testing::World& world, const StereoCamera& camera, const SE3& T_world_cam,
                   std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_int_distribution<int> bit(0, 255);
  MonoView view;
  view.snapshot.id = 0;
  view.snapshot.T_world_cam = T_world_cam;
  view.snapshot.T_cam_world = T_world_cam.inverse();
  for (int w = 0; w < static_cast<int>(world.points.size()); ++w) {
    const Eigen::Vector3d p_cam = view.snapshot.T_cam_world * world.points[w];
    if (p_cam.z() < 1.0) continue;
    map::KeyPointData kp;
    kp.uv_px = camera.project(p_cam) + Eigen::Vector2d(noise(rng), noise(rng));
    if (!camera.in_image(kp.uv_px, 3.0)) continue;
    kp.octave = world.octave[w];
    kp.descriptor = world.descriptors[w];
    for (int f = 0; f < 4; ++f) {
      const int b = bit(rng);
      kp.descriptor[b / 8] ^= static_cast<std::uint8_t>(1u << (b % 8));
    }
    view.snapshot.keypoints.push_back(kp);
    view.snapshot.point_of_keypoint.push_back(map::kNoPoint);
    view.world_of_keypoint.push_back(w);
  }
  return view;
}

TEST(NewPoints, FundamentalMatrixSatisfiesTheEpipolarConstraint) {
  const StereoCamera camera = test_camera();
  const SE3 T1 = pose_at_x(0.0);
  const SE3 T2 = SE3::exp((Vector6d() << 1.5, 0.2, 0.3, 0.02, -0.05, 0.01).finished());
  const Eigen::Matrix3d F21 = fundamental_2_1(camera, T1.inverse(), T2.inverse());
  const Eigen::Vector3d p_world(1.0, -0.5, 12.0);
  const Eigen::Vector2d x1 = camera.project(T1.inverse() * p_world);
  const Eigen::Vector2d x2 = camera.project(T2.inverse() * p_world);
  EXPECT_NEAR(x2.homogeneous().dot(F21 * x1.homogeneous()) / (F21 * x1.homogeneous()).head<2>().norm(), 0.0,
              1e-9);
  // A pixel 5 px off the match lies 5 px off the line at most.
  const Eigen::Vector3d line = F21 * x1.homogeneous();
  const double off = std::abs(line.dot(Eigen::Vector3d(x2.x(), x2.y() + 5.0, 1.0))) / line.head<2>().norm();
  EXPECT_GT(off, 1.0);
  EXPECT_LE(off, 5.0 + 1e-9);
}

TEST(NewPoints, EpipolarSearchAndTriangulationRecoverTheWorld) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(300, 11);
  std::mt19937 rng(3);
  MonoView v1 = mono_view(world, camera, pose_at_x(0.0), rng);
  MonoView v2 = mono_view(world, camera, pose_at_x(2.0, 0.03), rng);
  v2.snapshot.id = 1;
  const map::ScalePyramid pyramid;
  const NewPointParams params;

  const std::vector<KeypointMatch> matches =
      search_for_triangulation(camera, pyramid, v1.snapshot, v2.snapshot, params);
  int common = 0;
  for (int w1 : v1.world_of_keypoint) {
    common += std::count(v2.world_of_keypoint.begin(), v2.world_of_keypoint.end(), w1) > 0 ? 1 : 0;
  }
  int correct = 0;
  for (const KeypointMatch& m : matches) {
    correct += v1.world_of_keypoint[m.index1] == v2.world_of_keypoint[m.index2] ? 1 : 0;
  }
  ASSERT_GT(common, 500);
  EXPECT_GT(static_cast<double>(matches.size()), 0.9 * common);
  EXPECT_GE(correct, static_cast<int>(matches.size()) - 2);

  const std::vector<NewPoint> points =
      triangulate_matches(camera, pyramid, v1.snapshot, v2.snapshot, matches, params);
  EXPECT_GT(static_cast<double>(points.size()), 0.8 * matches.size());
  std::vector<double> relative_error;
  for (const NewPoint& p : points) {
    EXPECT_FALSE(p.from_stereo);
    const Eigen::Vector3d& truth = world.points[v1.world_of_keypoint[p.index1]];
    relative_error.push_back((p.p_world - truth).norm() / truth.z());
  }
  std::sort(relative_error.begin(), relative_error.end());
  ASSERT_FALSE(relative_error.empty());
  EXPECT_LT(relative_error[relative_error.size() / 2], 0.02);
  // The gates let no gross error through (a wrong match or a wild depth).
  EXPECT_LT(relative_error[relative_error.size() * 99 / 100], 0.15);
}

// The search visits only the candidates near each epipolar line
// (CandidateGrid); it must return what a loop over every candidate returns,
// including which of equally distant candidates wins. The reference below is
// that loop, written out plainly.
std::vector<KeypointMatch> brute_force_search(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                              const KeyFrameSnapshot& kf1, const KeyFrameSnapshot& kf2,
                                              const NewPointParams& params) {
  const Eigen::Matrix3d F21 = fundamental_2_1(camera, kf1.T_cam_world, kf2.T_cam_world);
  const Eigen::Vector3d c1_in_2 = kf2.T_cam_world * kf1.camera_center();
  const auto stereo = [](const map::KeyPointData& kp) { return kp.u_right_px >= 0.0 && kp.depth_m > 0.0; };
  std::vector<KeypointMatch> proposals;
  for (int i = 0; i < static_cast<int>(kf1.keypoints.size()); ++i) {
    const map::KeyPointData& kp1 = kf1.keypoints[i];
    const Eigen::Vector3d line = F21 * kp1.uv_px.homogeneous();
    int best = 1 << 30;
    int second = 1 << 30;
    int best_j = -1;
    for (int j = 0; j < static_cast<int>(kf2.keypoints.size()); ++j) {
      const map::KeyPointData& kp2 = kf2.keypoints[j];
      const double scale = pyramid.scale(kp2.octave);
      const bool near_epipole =
          c1_in_2.z() > 0.0 && (kp2.uv_px - camera.project(c1_in_2)).squaredNorm() < 100.0 * scale;
      if (!stereo(kp1) && !stereo(kp2) && near_epipole) continue;
      const double distance_px = std::abs(line.dot(kp2.uv_px.homogeneous())) / line.head<2>().norm();
      if (distance_px * distance_px > params.epipolar_chi2 * scale * scale) continue;
      const int d = map::descriptor_distance(kp1.descriptor, kp2.descriptor);
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_j < 0 || best > params.max_descriptor_distance) continue;
    if (second != (1 << 30) && !(best < params.ratio * second)) continue;
    proposals.push_back({i, best_j, best});
  }
  std::sort(proposals.begin(), proposals.end(), [](const KeypointMatch& a, const KeypointMatch& b) {
    return a.distance != b.distance ? a.distance < b.distance : a.index1 < b.index1;
  });
  std::vector<bool> taken(kf2.keypoints.size(), false);
  std::vector<KeypointMatch> matches;
  for (const KeypointMatch& m : proposals) {
    if (!taken[m.index2]) matches.push_back(m);
    taken[m.index2] = true;
  }
  std::sort(matches.begin(), matches.end(),
            [](const KeypointMatch& a, const KeypointMatch& b) { return a.index1 < b.index1; });
  return matches;
}

TEST(NewPoints, EpipolarSearchReturnsWhatALoopOverEveryCandidateReturns) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(600, 13);
  const map::ScalePyramid pyramid;
  // 0.9: more proposals than the default 0.6, so more of them compete for
  // keypoints; 1.5: no ratio test, so equally distant candidates (the
  // copies below) give matches and the tie rule decides which.
  const std::vector<double> ratios = {0.9, 1.5};
  // Sideways (near-horizontal lines), forwards (lines through an epipole
  // in the image, some near-vertical), upwards with a turn (near-vertical).
  const std::vector<SE3> second_poses = {pose_at_x(2.0, 0.03),
                                         SE3::exp((Vector6d() << 0.1, 0.05, 1.5, 0.01, 0.02, 0.0).finished()),
                                         SE3::exp((Vector6d() << 0.05, 1.2, 0.2, 0.1, 0.0, 0.3).finished())};
  int total_matches = 0;
  for (std::size_t pose = 0; pose < second_poses.size(); ++pose) {
    std::mt19937 rng(static_cast<unsigned>(40 + pose));
    MonoView v1 = mono_view(world, camera, pose_at_x(0.0), rng);
    MonoView v2 = mono_view(world, camera, second_poses[pose], rng);
    v2.snapshot.id = 1;
    // Stereo on every third keypoint of keyframe 1; in keyframe 2, copies
    // of every fifth keypoint 2 px to the left (ties of descriptor
    // distance; some copies fall into the cell before their original's).
    for (std::size_t k = 0; k < v1.snapshot.keypoints.size(); k += 3) {
      v1.snapshot.keypoints[k].u_right_px = v1.snapshot.keypoints[k].uv_px.x() - 10.0;
      v1.snapshot.keypoints[k].depth_m = 5.0;
    }
    const std::size_t n2 = v2.snapshot.keypoints.size();
    for (std::size_t k = 0; k < n2; k += 5) {
      map::KeyPointData copy = v2.snapshot.keypoints[k];
      copy.uv_px.x() -= 2.0;
      v2.snapshot.keypoints.push_back(copy);
      v2.snapshot.point_of_keypoint.push_back(map::kNoPoint);
    }
    for (const double ratio : ratios) {
      NewPointParams params;
      params.ratio = ratio;
      const std::vector<KeypointMatch> expected =
          brute_force_search(camera, pyramid, v1.snapshot, v2.snapshot, params);
      const std::vector<KeypointMatch> got =
          search_for_triangulation(camera, pyramid, v1.snapshot, v2.snapshot, params);
      ASSERT_EQ(got.size(), expected.size()) << "pose " << pose << " ratio " << ratio;
      for (std::size_t m = 0; m < got.size(); ++m) {
        EXPECT_TRUE(got[m].index1 == expected[m].index1 && got[m].index2 == expected[m].index2 &&
                    got[m].distance == expected[m].distance)
            << "pose " << pose << " ratio " << ratio << " match " << m;
      }
      total_matches += static_cast<int>(got.size());
    }
  }
  EXPECT_GT(total_matches, 300);
}

TEST(NewPoints, NoMatchesWithoutDescriptorAgreement) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(100, 5);
  const testing::World other_descriptors = make_world(100, 6);
  std::mt19937 rng(1);
  MonoView v1 = mono_view(world, camera, pose_at_x(0.0), rng);
  MonoView v2 = mono_view(world, camera, pose_at_x(2.0), rng);
  for (std::size_t i = 0; i < v2.snapshot.keypoints.size(); ++i) {
    v2.snapshot.keypoints[i].descriptor = other_descriptors.descriptors[v2.world_of_keypoint[i]];
  }
  EXPECT_TRUE(
      search_for_triangulation(camera, map::ScalePyramid{}, v1.snapshot, v2.snapshot, NewPointParams{})
          .empty());
}

TEST(Fuse, ProjectsPointsOntoTheirKeypoints) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(200, 21);
  std::mt19937 rng(2);
  MonoView target = mono_view(world, camera, pose_at_x(1.0), rng);
  target.snapshot.id = 5;
  std::vector<PointSnapshot> points;
  for (int w = 0; w < static_cast<int>(world.points.size()); ++w) {
    PointSnapshot p;
    p.id = 1000 + w;
    p.p_world = world.points[w];
    p.normal = (world.points[w] - pose_at_x(0.0).translation()).normalized();
    // As MapData derives it from the creating view (here at the origin).
    p.max_distance_m = world.points[w].norm() * std::pow(1.2, world.octave[w]);
    p.min_distance_m = p.max_distance_m / std::pow(1.2, 7);
    p.descriptor = world.descriptors[w];
    p.observed_by = {0};
    points.push_back(p);
  }
  const map::KeypointGrid grid = make_keypoint_grid(camera, target.snapshot);
  const auto proposals =
      fuse_into_keyframe(camera, map::ScalePyramid{}, target.snapshot, grid, points, FuseParams{});
  EXPECT_GT(static_cast<double>(proposals.size()), 0.95 * target.snapshot.keypoints.size());
  for (const FuseProposal& f : proposals) {
    EXPECT_EQ(f.point - 1000, target.world_of_keypoint[f.index]);
    EXPECT_EQ(f.keyframe, 5);
  }
  // A point the keyframe already observes is not proposed again.
  for (auto& p : points) p.observed_by = {5};
  EXPECT_TRUE(
      fuse_into_keyframe(camera, map::ScalePyramid{}, target.snapshot, grid, points, FuseParams{}).empty());
}

TEST(KeyframeCulling, RedundantWhenThreeOthersSeeTheCloseStereoPoints) {
  map::MapData m;
  auto make_kf = [](double x_m, int n, int octave) {
    map::KeyFrame kf;
    kf.T_world_cam = pose_at_x(x_m);
    for (int i = 0; i < n; ++i) {
      map::KeyPointData kp;
      kp.uv_px = {10.0 + i, 10.0};
      kp.octave = octave;
      kp.u_right_px = 5.0 + i;
      kp.depth_m = 10.0;
      kf.keypoints.push_back(kp);
    }
    return kf;
  };
  const map::KeyFrameId k0 = m.add_keyframe(make_kf(0.0, 20, 0));
  std::vector<map::PointId> pids;
  for (int i = 0; i < 20; ++i) pids.push_back(m.add_point({0.1 * i, 0, 10}, k0, i));
  std::vector<map::KeyFrameId> ids{k0};
  for (int k = 1; k <= 3; ++k) {
    map::KeyFrame kf = make_kf(0.5 * k, 20, k == 3 ? 4 : 0);  // keyframe 3 sees at a coarse scale
    kf.point_of_keypoint = pids;
    ids.push_back(m.add_keyframe(std::move(kf)));
  }
  // Keyframe 1's points are seen by 0, 2 (same scale) and 3 (octave 4 > 0 + 1): only 2 count.
  EXPECT_EQ(count_redundant_points(m, ids[1], 40.0).redundant_points, 0);
  map::KeyFrame kf4 = make_kf(2.0, 20, 1);
  kf4.point_of_keypoint = pids;
  ids.push_back(m.add_keyframe(std::move(kf4)));
  EXPECT_EQ(count_redundant_points(m, ids[1], 40.0).redundant_points, 20);
  EXPECT_TRUE(is_keyframe_redundant(m, ids[1], 0.9, 40.0));
  // Far points do not decide.
  EXPECT_EQ(count_redundant_points(m, ids[1], 5.0).close_points, 0);
  EXPECT_FALSE(is_keyframe_redundant(m, ids[1], 0.9, 5.0));
  // Candidates: older than the current keyframe, never the first.
  const auto candidates = redundant_keyframes(m, ids[4], 10, 0.9, 40.0);
  EXPECT_EQ(std::count(candidates.begin(), candidates.end(), k0), 0);
  EXPECT_EQ(std::count(candidates.begin(), candidates.end(), ids[4]), 0);
  EXPECT_EQ(std::count(candidates.begin(), candidates.end(), ids[1]), 1);
}

}  // namespace
}  // namespace sitepose::mapping
