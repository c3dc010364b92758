// The SE(3) pose-graph optimiser (loop/pose_graph.hpp) on a synthetic
// drifted loop: a roller's 16 m lane driven out and back, odometry edges
// measured with a small heading and scale bias, one loop edge from the last
// pose to the first with the true relative pose.

#include "sitepose/loop/pose_graph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace sitepose::loop {
namespace {

constexpr int kNodes = 33;  // every metre, out and back

// Out along +x to 16 m, turn 180 degrees, back (camera z forward).
std::vector<SE3> true_poses() {
  std::vector<SE3> out;
  for (int i = 0; i < kNodes; ++i) {
    const double x = i <= 16 ? i : 32 - i;
    const double yaw = i <= 16 ? 0.0 : M_PI;
    out.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())),
                     Eigen::Vector3d(x, 0.0, 0.1 * (i % 2)));
  }
  return out;
}

SE3 biased(const SE3& T_i_j) {
  // 0.3 degrees of heading and 1 % of distance per metre: odometry drift.
  const SE3 heading(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * M_PI / 180.0, Eigen::Vector3d::UnitY())),
                    Eigen::Vector3d::Zero());
  return heading * SE3(T_i_j.rotation(), 1.01 * T_i_j.translation());
}

PoseGraphInput drifted_loop(std::vector<SE3>& truth) {
  truth = true_poses();
  PoseGraphInput in;
  in.T_world_node.push_back(truth[0]);
  for (int i = 0; i + 1 < kNodes; ++i) {
    const SE3 measured = biased(truth[i].inverse() * truth[i + 1]);
    in.edges.push_back({i, i + 1, measured, 1.0});
    in.T_world_node.push_back(in.T_world_node.back() * measured);
  }
  in.edges.push_back({kNodes - 1, 0, truth[kNodes - 1].inverse() * truth[0], 1.0});
  in.fixed.assign(kNodes, false);
  in.fixed[0] = true;
  return in;
}

double position_error(const SE3& a, const SE3& b) { return (a.translation() - b.translation()).norm(); }

TEST(PoseGraph, ResidualIsZeroAtTheMeasuredRelativePose) {
  const std::vector<SE3> truth = true_poses();
  const PoseGraphEdge e{0, 20, truth[0].inverse() * truth[20], 1.0};
  EXPECT_LT(pose_graph_residual(truth[0], truth[20], e).norm(), 1e-12);
  // A 0.1 m shift of the far end shows as 0.1 m in the residual.
  const SE3 moved = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1, 0, 0)) * truth[20];
  EXPECT_NEAR(pose_graph_residual(truth[0], moved, e).head<3>().norm(), 0.1, 1e-12);
}

TEST(PoseGraph, ReducesTheErrorAtTheLoopAndKeepsTheFirstPoseFixed) {
  std::vector<SE3> truth;
  const PoseGraphInput in = drifted_loop(truth);
  const double before_m = position_error(in.T_world_node.back(), truth.back());
  double worst_before_m = 0.0;
  for (int i = 0; i < kNodes; ++i)
    worst_before_m = std::max(worst_before_m, position_error(in.T_world_node[i], truth[i]));
  const Expected<PoseGraphResult> r = optimise_pose_graph(in);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  const double after_m = position_error(r->T_world_node.back(), truth.back());
  double worst_after_m = 0.0;
  for (int i = 0; i < kNodes; ++i)
    worst_after_m = std::max(worst_after_m, position_error(r->T_world_node[i], truth[i]));
  std::printf(
      "pose graph: error at the loop %.4f -> %.4f m (x%.1f), worst %.4f -> %.4f m, cost %.4g -> %.4g, "
      "%d iterations\n",
      before_m, after_m, before_m / after_m, worst_before_m, worst_after_m, r->initial_cost, r->final_cost,
      r->iterations);
  EXPECT_GT(before_m, 0.5) << "the synthetic drift is too small to test anything";
  EXPECT_LT(after_m, before_m / 10.0);
  EXPECT_LT(worst_after_m, worst_before_m / 2.0);
  EXPECT_LT(r->final_cost, r->initial_cost);
  EXPECT_EQ(r->T_world_node[0].matrix(), in.T_world_node[0].matrix());
}

TEST(PoseGraph, WithoutTheLoopEdgeNothingMoves) {
  std::vector<SE3> truth;
  PoseGraphInput in = drifted_loop(truth);
  in.edges.pop_back();
  const Expected<PoseGraphResult> r = optimise_pose_graph(in);
  ASSERT_TRUE(r.has_value());
  for (int i = 0; i < kNodes; ++i) EXPECT_LT(position_error(r->T_world_node[i], in.T_world_node[i]), 1e-6);
}

TEST(PoseGraph, RefusesBadInput) {
  std::vector<SE3> truth;
  PoseGraphInput in = drifted_loop(truth);
  PoseGraphInput no_fixed = in;
  no_fixed.fixed.assign(kNodes, false);
  EXPECT_FALSE(optimise_pose_graph(no_fixed).has_value());
  PoseGraphInput bad_edge = in;
  bad_edge.edges.push_back({0, kNodes, SE3(), 1.0});
  EXPECT_FALSE(optimise_pose_graph(bad_edge).has_value());
}

}  // namespace
}  // namespace sitepose::loop
