#include "sitepose/loop/pose_graph.hpp"

#include <ceres/ceres.h>

#include <array>
#include <memory>
#include <string>

namespace sitepose::loop {
namespace {

struct RelativePoseCost {
  RelativePoseCost(const SE3& T_from_to, double weight)
      : q_measured(T_from_to.rotation()), t_measured(T_from_to.translation()), weight(weight) {}

  template <typename T>
  bool operator()(const T* q_from_data, const T* t_from_data, const T* q_to_data, const T* t_to_data,
                  T* residual_data) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_from(q_from_data);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_from(t_from_data);
    const Eigen::Map<const Eigen::Quaternion<T>> q_to(q_to_data);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_to(t_to_data);
    const Eigen::Quaternion<T> q_from_inv = q_from.conjugate();
    const Eigen::Quaternion<T> q_estimate = q_from_inv * q_to;
    const Eigen::Matrix<T, 3, 1> t_estimate = q_from_inv * (t_to - t_from);
    const Eigen::Quaternion<T> dq = q_measured.template cast<T>().conjugate() * q_estimate;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual_data);
    r.template head<3>() = T(weight) * (t_estimate - t_measured.template cast<T>());
    r.template tail<3>() = T(2.0 * weight) * dq.vec();
    return true;
  }

  Eigen::Quaterniond q_measured;
  Eigen::Vector3d t_measured;
  double weight;
};

struct NodeBlocks {
  std::array<double, 4> q{};  // x, y, z, w
  std::array<double, 3> t{};
};

Status check_input(const PoseGraphInput& input) {
  const std::size_t n = input.T_world_node.size();
  if (input.fixed.size() != n) {
    return make_error(ErrorCode::kInvalidArgument, "pose graph: fixed flags for " +
                                                       std::to_string(input.fixed.size()) + " of " +
                                                       std::to_string(n) + " nodes");
  }
  bool any_fixed = false;
  for (bool f : input.fixed) any_fixed = any_fixed || f;
  if (!any_fixed) return make_error(ErrorCode::kInvalidArgument, "pose graph: no fixed node (free gauge)");
  for (const PoseGraphEdge& e : input.edges) {
    if (e.from < 0 || e.to < 0 || static_cast<std::size_t>(e.from) >= n ||
        static_cast<std::size_t>(e.to) >= n || e.from == e.to) {
      return make_error(ErrorCode::kInvalidArgument, "pose graph: edge " + std::to_string(e.from) + " -> " +
                                                         std::to_string(e.to) + " names a missing node");
    }
  }
  return ok_status();
}

}  // namespace

Vector6d pose_graph_residual(const SE3& T_world_from, const SE3& T_world_to, const PoseGraphEdge& edge) {
  const RelativePoseCost cost(edge.T_from_to, edge.weight);
  const Eigen::Quaterniond& q_from = T_world_from.rotation();
  const Eigen::Quaterniond& q_to = T_world_to.rotation();
  Vector6d r;
  cost(q_from.coeffs().data(), T_world_from.translation().data(), q_to.coeffs().data(),
       T_world_to.translation().data(), r.data());
  return r;
}

Expected<PoseGraphResult> optimise_pose_graph(const PoseGraphInput& input) {
  SITEPOSE_TRY_STATUS(check_input(input));
  std::vector<NodeBlocks> nodes(input.T_world_node.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Eigen::Quaterniond q = input.T_world_node[i].rotation();
    nodes[i].q = {q.x(), q.y(), q.z(), q.w()};
    const Eigen::Vector3d& t = input.T_world_node[i].translation();
    nodes[i].t = {t.x(), t.y(), t.z()};
  }
  ceres::Problem problem;
  for (const PoseGraphEdge& e : input.edges) {
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
        new RelativePoseCost(e.T_from_to, e.weight));
    NodeBlocks& a = nodes[static_cast<std::size_t>(e.from)];
    NodeBlocks& b = nodes[static_cast<std::size_t>(e.to)];
    problem.AddResidualBlock(cost, nullptr, a.q.data(), a.t.data(), b.q.data(), b.t.data());
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (!problem.HasParameterBlock(nodes[i].q.data())) continue;  // a node without edges keeps its pose
    problem.SetManifold(nodes[i].q.data(), new ceres::EigenQuaternionManifold);
    if (input.fixed[i]) {
      problem.SetParameterBlockConstant(nodes[i].q.data());
      problem.SetParameterBlockConstant(nodes[i].t.data());
    }
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = input.max_iterations;
  options.num_threads = 1;
  options.minimizer_progress_to_stdout = false;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (summary.termination_type == ceres::FAILURE) {
    return make_error(ErrorCode::kRuntime, "pose graph: Ceres failed: " + summary.message);
  }
  PoseGraphResult result;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = static_cast<int>(summary.iterations.size());
  result.T_world_node.reserve(nodes.size());
  for (const NodeBlocks& n : nodes) {
    const Eigen::Quaterniond q(n.q[3], n.q[0], n.q[1], n.q[2]);
    result.T_world_node.emplace_back(q.normalized(), Eigen::Vector3d(n.t[0], n.t[1], n.t[2]));
  }
  return result;
}

}  // namespace sitepose::loop
