#pragma once
// Pose-graph optimisation over SE(3) (ORB-SLAM2 OptimizeEssentialGraph,
// stereo: no scale), with Ceres.
//
// Nodes: T_world_node of each keyframe. Parameter blocks per node: the
// rotation as an Eigen quaternion [x, y, z, w] on ceres::EigenQuaternion-
// Manifold and the translation (m), so the step stays on SE(3).
// Edge i -> j with measurement T_i_j (what T_world_i^-1 * T_world_j was
// before the loop was found): with the estimate T_i_j' = T_world_i^-1 *
// T_world_j,
//   r = w * [ t(T_i_j') - t(T_i_j)               (m, in frame i)
//             2 vec(q(T_i_j)^-1 * q(T_i_j')) ]   (rad, small-angle)
// so r = 0 when the relative pose is the measured one; information is the
// identity times w^2 (ORB-SLAM2 uses the identity for every edge).
//
// Thread-safety: pure function of its input.

#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"

namespace sitepose::loop {

struct PoseGraphEdge {
  int from = 0;  // node indices
  int to = 0;
  SE3 T_from_to;  // measured relative pose
  double weight = 1.0;
};

struct PoseGraphInput {
  std::vector<SE3> T_world_node;  // initial values
  std::vector<bool> fixed;        // per node (at least one, else the gauge is free)
  std::vector<PoseGraphEdge> edges;
  int max_iterations = 20;  // ORB-SLAM2: 20 Levenberg-Marquardt iterations
};

struct PoseGraphResult {
  std::vector<SE3> T_world_node;
  double initial_cost = 0.0;  // Ceres cost (1/2 sum |r|^2)
  double final_cost = 0.0;
  int iterations = 0;
};

// kInvalidArgument for an edge naming a missing node, sizes that differ or
// no fixed node; kRuntime when Ceres fails.
Expected<PoseGraphResult> optimise_pose_graph(const PoseGraphInput& input);

// The residual of one edge at the given poses (the vector above), for tests
// and diagnostics.
Vector6d pose_graph_residual(const SE3& T_world_from, const SE3& T_world_to, const PoseGraphEdge& edge);

}  // namespace sitepose::loop
