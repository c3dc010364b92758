// Global BA after a loop: the whole map is copied, solved and applied; what
// the mapper made since the copy follows the spanning tree.

#include "sitepose/loop/global_ba.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "sitepose/testing/cameras.hpp"

namespace sitepose::loop {
namespace {

constexpr int kPoints = 40;

StereoCamera test_camera() { return testing::centred_camera(640, 360, 500.0, 0.5); }

Eigen::Vector3d world_point(int i) { return {-2.0 + 0.1 * i, -1.0 + 0.05 * (i % 7), 8.0 + 0.1 * (i % 5)}; }

SE3 camera_at(double x_m) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x_m, 0.0, 0.0)); }

// A keyframe at T_world_cam seeing every world point; the points it is the
// first to see are created (ids in `ids`, kNoPoint = not yet).
map::KeyFrameId add_keyframe(map::MapData& m, const SE3& T_world_cam, std::vector<map::PointId>& ids) {
  const StereoCamera camera = test_camera();
  map::KeyFrame kf;
  kf.T_world_cam = T_world_cam;
  for (int i = 0; i < kPoints; ++i) {
    const Eigen::Vector3d p_cam = T_world_cam.inverse() * world_point(i);
    map::KeyPointData kp;
    kp.uv_px = camera.project(p_cam);
    kp.u_right_px = camera.project_right_u(p_cam);
    kp.depth_m = p_cam.z();
    kf.keypoints.push_back(kp);
    kf.point_of_keypoint.push_back(ids[static_cast<std::size_t>(i)]);
  }
  const map::KeyFrameId id = m.add_keyframe(kf);
  for (int i = 0; i < kPoints; ++i) {
    if (ids[static_cast<std::size_t>(i)] == map::kNoPoint)
      ids[static_cast<std::size_t>(i)] = m.add_point(world_point(i), id, i);
  }
  for (const auto& [kid, k] : m.keyframes()) m.update_connections(kid);
  return id;
}

// Three keyframes 0.5 m apart seeing every point, and the global BA's copy.
struct ThreeKeyFrames {
  map::MapData m;
  std::vector<map::PointId> ids = std::vector<map::PointId>(kPoints, map::kNoPoint);
  mapping::LocalBaProblem problem;
};

ThreeKeyFrames three_keyframes() {
  ThreeKeyFrames t;
  for (int k = 0; k < 3; ++k) add_keyframe(t.m, camera_at(0.5 * k), t.ids);
  t.problem = mapping::build_global_ba_problem(t.m);
  return t;
}

// A "solve" that moves every free keyframe 0.1 m along y and puts every
// point 0.2 m lower.
const SE3 kSolveShift(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.1, 0.0));

optim::LocalBaResult shifted_solve(const mapping::LocalBaProblem& problem) {
  optim::LocalBaResult result;
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    const SE3 T_world_cam = problem.input.T_cam_world[k].inverse();
    result.T_cam_world.push_back(problem.input.keyframe_fixed[k] != 0
                                     ? problem.input.T_cam_world[k]
                                     : (kSolveShift * T_world_cam).inverse());
  }
  for (const Eigen::Vector3d& p : problem.input.p_world)
    result.p_world.push_back(p + Eigen::Vector3d(0, 0, -0.2));
  return result;
}

TEST(GlobalBa, CopiesTheWholeMapWithTheFirstKeyFrameFixed) {
  auto [m, ids, problem] = three_keyframes();
  ASSERT_EQ(problem.keyframe_ids.size(), 3u);
  EXPECT_EQ(problem.n_fixed_keyframes, 1);
  EXPECT_EQ(problem.n_free_keyframes, 2);
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    EXPECT_EQ(problem.input.keyframe_fixed[k] != 0, problem.keyframe_ids[k] == m.first_keyframe());
  }
  EXPECT_EQ(problem.point_ids.size(), static_cast<std::size_t>(kPoints));
  EXPECT_EQ(problem.input.observations.size(), static_cast<std::size_t>(3 * kPoints));
}

TEST(GlobalBaApply, SetsTheCopyAndMovesWhatWasMadeSinceWithItsAncestor) {
  auto [m, ids, problem] = three_keyframes();

  // The mapper goes on meanwhile: a keyframe past the last one, and a
  // point only it sees.
  std::vector<map::PointId> shared = ids;
  shared.back() = map::kNoPoint;  // its own point
  const map::KeyFrameId made_since = add_keyframe(m, camera_at(1.5), shared);
  const map::PointId point_since = shared.back();
  ASSERT_NE(point_since, ids.back());
  // Its parent: the last copied keyframe (every keyframe here sees the same
  // points, so the tie would go to the first).
  const map::KeyFrameId last_copied = problem.keyframe_ids.back();
  m.keyframe(m.keyframe(made_since)->parent)->children.erase(made_since);
  m.keyframe(made_since)->parent = last_copied;
  m.keyframe(last_copied)->children.insert(made_since);
  ASSERT_EQ(m.point(point_since)->reference_keyframe, made_since);
  const Eigen::Vector3d point_since_before = m.point(point_since)->p_world;
  const SE3 made_since_before = m.keyframe(made_since)->T_world_cam;

  const optim::LocalBaResult result = shifted_solve(problem);
  const SE3& shift = kSolveShift;
  const SE3 first_before = m.keyframe(m.first_keyframe())->T_world_cam;

  const GlobalBaApplied applied = apply_global_ba(m, problem, result);
  EXPECT_EQ(applied.keyframes_moved, 4);
  EXPECT_EQ(applied.points_optimised, kPoints);
  EXPECT_EQ(m.keyframe(m.first_keyframe())->T_world_cam.matrix(), first_before.matrix());
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    EXPECT_TRUE(m.keyframe(problem.keyframe_ids[k])
                    ->T_world_cam.matrix()
                    .isApprox(result.T_cam_world[k].inverse().matrix(), 1e-12));
  }
  for (std::size_t pi = 0; pi < problem.point_ids.size(); ++pi) {
    EXPECT_TRUE(m.point(problem.point_ids[pi])->p_world.isApprox(result.p_world[pi], 1e-12));
  }
  // Made since: moved with the last copied keyframe's correction.
  EXPECT_TRUE(
      m.keyframe(made_since)->T_world_cam.matrix().isApprox((shift * made_since_before).matrix(), 1e-12));
  EXPECT_TRUE(m.point(point_since)->p_world.isApprox(shift * point_since_before, 1e-12));
  EXPECT_TRUE(applied.newest_correction.matrix().isApprox(shift.matrix(), 1e-12));
}

// The move planned under the read lock and committed later leaves the map
// exactly as the apply under one lock, geometry included (computed from the
// moved keyframes before they moved).
TEST(GlobalBaApply, PlannedThenCommittedEqualsAppliedAtOnce) {
  auto [m, ids, problem] = three_keyframes();
  const optim::LocalBaResult result = shifted_solve(problem);
  const Eigen::Vector3d normal_before = m.point(ids.front())->normal;
  map::MapData at_once = m;
  apply_global_ba(at_once, problem, result);
  const MapMove move = plan_global_ba_move(m, problem, result);
  EXPECT_EQ(move.last_keyframe, m.last_keyframe());
  const GraphApplied committed = commit_map_move(m, move);
  EXPECT_EQ(committed.points_set, kPoints);
  for (const auto& [id, kf] : at_once.keyframes()) {
    EXPECT_EQ(m.keyframe(id)->T_world_cam.matrix(), kf.T_world_cam.matrix());
  }
  for (const auto& [pid, p] : at_once.points()) {
    const map::MapPoint& got = *m.point(pid);
    EXPECT_EQ(got.p_world, p.p_world);
    EXPECT_EQ(got.normal, p.normal);
    EXPECT_EQ(got.min_distance_m, p.min_distance_m);
    EXPECT_EQ(got.max_distance_m, p.max_distance_m);
    // ... and it is the geometry of the committed keyframes.
    m.update_point_geometry(pid);
    EXPECT_EQ(m.point(pid)->normal, p.normal);
    EXPECT_EQ(m.point(pid)->max_distance_m, p.max_distance_m);
  }
  // The move turned the viewing directions: the geometry was recomputed.
  EXPECT_GT((m.point(ids.front())->normal - normal_before).norm(), 1e-3);
}

// A keyframe the tracker inserts after the plan is not in it (the map's last
// keyframe says so): the caller plans again under the write lock.
TEST(GlobalBaApply, APlanMadeBeforeAKeyFrameWasInsertedMissesIt) {
  auto [m, ids, problem] = three_keyframes();
  const optim::LocalBaResult result = shifted_solve(problem);
  const MapMove stale = plan_global_ba_move(m, problem, result);
  const map::KeyFrameId inserted = add_keyframe(m, camera_at(1.5), ids);
  EXPECT_NE(m.last_keyframe(), stale.last_keyframe);
  const auto moves = [&](const MapMove& move) {
    return std::any_of(move.T_world_cam.begin(), move.T_world_cam.end(),
                       [&](const auto& entry) { return entry.first == inserted; });
  };
  EXPECT_FALSE(moves(stale));
  EXPECT_TRUE(moves(plan_global_ba_move(m, problem, result)));
}

TEST(GlobalBaApply, SolvesADisturbedMapBackToItsObservations) {
  map::MapData m;
  std::vector<map::PointId> ids(kPoints, map::kNoPoint);
  for (int k = 0; k < 4; ++k) add_keyframe(m, camera_at(0.5 * k), ids);
  const std::vector<SE3> truth = {camera_at(0.0), camera_at(0.5), camera_at(1.0), camera_at(1.5)};
  // Disturb the free keyframes by 3 cm and the points by 2 cm.
  for (auto& [id, kf] : m.keyframes()) {
    if (id != m.first_keyframe())
      m.keyframe(id)->T_world_cam =
          SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.03, -0.03, 0.03)) * kf.T_world_cam;
  }
  for (const map::PointId pid : ids) m.point(pid)->p_world += Eigen::Vector3d(0.02, 0.0, -0.02);
  const mapping::LocalBaProblem problem = mapping::build_global_ba_problem(m);
  const optim::LocalBa solver(test_camera(), config::MappingConfig{}, config::TrackingConfig{});
  const Expected<optim::LocalBaResult> result = solver.solve(problem.input, nullptr);
  ASSERT_TRUE(result.has_value()) << result.error().message;
  apply_global_ba(m, problem, *result);
  for (std::size_t k = 0; k < problem.keyframe_ids.size(); ++k) {
    const SE3& T = m.keyframe(problem.keyframe_ids[k])->T_world_cam;
    EXPECT_LT(
        (T.translation() - truth[static_cast<std::size_t>(problem.keyframe_ids[k])].translation()).norm(),
        1e-4)
        << "keyframe " << problem.keyframe_ids[k];
  }
  for (int i = 0; i < kPoints; ++i) {
    EXPECT_LT((m.point(ids[static_cast<std::size_t>(i)])->p_world - world_point(i)).norm(), 1e-4)
        << "point " << i;
  }
}

}  // namespace
}  // namespace sitepose::loop
