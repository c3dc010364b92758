#include "sitepose/tracking/pose_refinement.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include "sitepose/testing/pose_scene.hpp"

namespace sitepose::tracking {
namespace {

using namespace testing;  // NOLINT: test helpers

// A standing camera whose established background is partly hidden by a
// machine that moved `machine_travel_m` since its points were made: the
// machine's (fresh) map points sit where it was, its keypoints where it is.
struct StandingScene {
  StereoCamera camera = hd_camera();
  SE3 T_cam_world_true = test_pose_world_cam().inverse();
  PreparedFrame frame;
  std::vector<PointView> points;
  std::vector<int> match_of_keypoint;  // keypoint k matched to points[k] (all matched)
};

// Adds `n` points at depth [min, max] m, observed (noisy) where they are now;
// the map holds them shifted by -travel (world x), with the given span, seen
// by the map from this camera (normal along the ray, distance range 0.5x-2x).
void add_points(StandingScene& s, int n, double min_depth_m, double max_depth_m, double travel_m,
                double observed_span_s, std::mt19937& rng) {
  const SE3 T_world_cam = s.T_cam_world_true.inverse();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_now = T_world_cam * random_point_cam(s.camera, min_depth_m, max_depth_m, rng);
    optim::PoseObservation o = exact_observation(s.camera, s.T_cam_world_true, p_now, 0, false);
    add_noise(o, rng);
    PointView view;
    view.id = static_cast<map::PointId>(s.points.size() + 1);
    view.p_world = p_now - Eigen::Vector3d(travel_m, 0.0, 0.0);
    const Eigen::Vector3d ray = view.p_world - T_world_cam.translation();
    view.normal = ray.normalized();
    view.min_distance_m = 0.5 * ray.norm();
    view.max_distance_m = 2.0 * ray.norm();
    view.observed_span_s = observed_span_s;
    s.match_of_keypoint.push_back(static_cast<int>(s.points.size()));
    s.points.push_back(view);
    s.frame.uv_px.push_back(o.uv_left_px);
    s.frame.octave.push_back(0);
    s.frame.features.u_right.push_back(o.u_right_px);
    s.frame.features.depth_m.push_back(-1.0);
  }
}

constexpr double kEstablished = 2.0 * kEstablishedSpanS;

StandingScene machine_in_front(int n_background, int n_machine) {
  std::mt19937 rng(7);
  StandingScene s;
  add_points(s, n_background, 5.0, 25.0, 0.0, kEstablished, rng);
  add_points(s, n_machine, 4.0, 6.0, 0.4, 0.0, rng);  // moved 0.4 m since its keyframe
  return s;
}

PassResult solve(const StandingScene& s, bool established_first) {
  const optim::MotionOnlyBa motion_ba(s.camera, config::TrackingConfig{});
  const map::ScalePyramid pyramid;
  PassResult result;
  result.T_cam_world = s.T_cam_world_true;  // a standing camera's prediction
  if (established_first) {
    optimise_pose_established_first(motion_ba, s.camera, pyramid, s.frame, s.points, s.match_of_keypoint,
                                    result);
  } else {
    optimise_pose(motion_ba, pyramid, s.frame, s.points, s.match_of_keypoint, result);
  }
  return result;
}

TEST(EstablishedFirst, FreshPointsOnAMovedMachineDoNotDragThePose) {
  const StandingScene s = machine_in_front(40, 100);
  const PassResult plain = solve(s, false);
  const PassResult held = solve(s, true);
  StandingScene background = s;
  for (int k = 40; k < s.frame.size(); ++k) background.match_of_keypoint[k] = -1;
  const PassResult background_only = solve(background, false);
  // All matches alike: the machine's 100 points win (0.54 m off).
  EXPECT_GT(translation_error_m(plain.T_cam_world, s.T_cam_world_true), 0.1);
  // Established first: where the background alone puts it (1.9 cm off with
  // 40 points at 5-25 m and 1 px noise).
  EXPECT_LT(translation_error_m(held.T_cam_world, background_only.T_cam_world), 0.001);
  EXPECT_LT(translation_error_m(held.T_cam_world, s.T_cam_world_true), 0.05);
  int machine_inliers = 0;
  for (int k = 40; k < s.frame.size(); ++k) machine_inliers += held.point_of_keypoint[k] != map::kNoPoint;
  EXPECT_EQ(machine_inliers, 0);
  EXPECT_GE(held.n_inliers, 36);  // the background, less the noise's tail
}

TEST(EstablishedFirst, FreshPointsThatFitJoinTheEstablishedOnes) {
  std::mt19937 rng(3);
  StandingScene s;
  add_points(s, 30, 8.0, 30.0, 0.0, kEstablished, rng);
  add_points(s, 60, 4.0, 20.0, 0.0, 0.0, rng);  // new static points
  const PassResult held = solve(s, true);
  EXPECT_LT(translation_error_m(held.T_cam_world, s.T_cam_world_true), 0.01);
  EXPECT_GE(held.n_inliers, 80);
}

TEST(EstablishedFirst, HiddenEstablishedMapGivesNoPose) {
  // 60 established points in view, 10 of them matched, 100 fresh matches.
  StandingScene s = machine_in_front(60, 100);
  for (int k = 10; k < 60; ++k) s.match_of_keypoint[k] = -1;
  const PassResult result = solve(s, true);
  EXPECT_EQ(result.n_inliers, 0);
  EXPECT_NE(result.failure.find("established map is hidden"), std::string::npos) << result.failure;
}

// The same frame, but the map saw its established points from the side (a
// camera turning past structures it mapped head-on: their mean viewing
// direction 90 deg from the ray now). No search could match them from
// here, so they are not "in view": nothing is hidden, all matches count.
TEST(EstablishedFirst, PointsSeenFromTheSideAreNotInViewSoNothingIsHidden) {
  StandingScene s = machine_in_front(60, 100);
  for (int k = 10; k < 60; ++k) s.match_of_keypoint[k] = -1;
  for (int k = 0; k < 60; ++k) {
    const Eigen::Vector3d n = s.points[k].normal;
    s.points[k].normal = n.cross(Eigen::Vector3d::UnitY()).normalized();
  }
  const PassResult result = solve(s, true);
  EXPECT_EQ(result.established_in_view, 0);
  EXPECT_TRUE(result.failure.empty()) << result.failure;
  EXPECT_GT(result.n_inliers, 0);
}

// Enough established matches to solve on (>= kMinEstablishedMatches), but
// a small share of the established points in view: a pose, not an OK one.
TEST(EstablishedFirst, FewOfTheEstablishedPointsInViewMatchedIsHidden) {
  for (const int matched : {30, 60}) {  // of 300 in view: 10 %, 20 %
    StandingScene s = machine_in_front(300, 100);
    for (int k = matched; k < 300; ++k) s.match_of_keypoint[k] = -1;
    const PassResult result = solve(s, true);
    EXPECT_EQ(result.established_in_view, 300);
    EXPECT_EQ(result.established_matched, matched);
    EXPECT_GE(result.n_inliers, matched - 5) << matched;
    EXPECT_EQ(established_map_hidden(result), matched < kMinMatchedEstablishedShare * 300) << matched;
  }
}

TEST(EstablishedFirst, WithoutAnEstablishedMapInViewAllMatchesCount) {
  // A new map (or new ground): nothing established to judge by.
  std::mt19937 rng(5);
  StandingScene s;
  add_points(s, 80, 4.0, 20.0, 0.0, 0.0, rng);
  const PassResult result = solve(s, true);
  EXPECT_LT(translation_error_m(result.T_cam_world, s.T_cam_world_true), 0.01);
  EXPECT_GE(result.n_inliers, 70);
}

TEST(EstablishedFirst, FewFreshMatchesIsPlainOptimisation) {
  std::mt19937 rng(9);
  StandingScene s;
  add_points(s, 80, 8.0, 30.0, 0.0, kEstablished, rng);
  add_points(s, 20, 4.0, 6.0, 0.4, 0.0, rng);
  const PassResult plain = solve(s, false);
  const PassResult result = solve(s, true);
  EXPECT_EQ(result.T_cam_world.translation(), plain.T_cam_world.translation());
  EXPECT_EQ(result.point_of_keypoint, plain.point_of_keypoint);
}

}  // namespace
}  // namespace sitepose::tracking
