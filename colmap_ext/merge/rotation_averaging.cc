#include "colmap_ext/merge/rotation_averaging.h"

#include "colmap_ext/util/union_find.h"

#include "colmap/math/math.h"
#include "colmap/optim/least_absolute_deviations.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <numeric>
#include <queue>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

namespace colmap {
namespace {

// The shortest representation: Eigen's angle is in [0, pi].
Eigen::Vector3d RotationToAngleAxis(const Eigen::Quaterniond& rotation) {
  const Eigen::AngleAxisd angle_axis(rotation.normalized());
  return angle_axis.angle() * angle_axis.axis();
}

Eigen::Quaterniond AngleAxisToRotation(const Eigen::Vector3d& angle_axis) {
  const double angle = angle_axis.norm();
  if (angle < 1e-16) {
    return Eigen::Quaterniond::Identity();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, angle_axis / angle));
}

// Chains the relative rotations along a maximum spanning tree, rooted at
// the reference node. Returns false if the graph is not connected.
bool InitializeFromSpanningTree(
    const int num_nodes,
    const std::vector<RelativeRotation>& relative_rotations,
    const int reference_node,
    std::vector<Eigen::Quaterniond>* rotations) {
  // Kruskal on descending weights.
  std::vector<size_t> order(relative_rotations.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return relative_rotations[a].weight > relative_rotations[b].weight;
  });
  DisjointSets sets(num_nodes);
  std::vector<std::vector<size_t>> tree_edges(num_nodes);
  for (const size_t edge_idx : order) {
    const RelativeRotation& edge = relative_rotations[edge_idx];
    if (sets.Union(edge.node1, edge.node2)) {
      tree_edges[edge.node1].push_back(edge_idx);
      tree_edges[edge.node2].push_back(edge_idx);
    }
  }

  rotations->assign(num_nodes, Eigen::Quaterniond::Identity());
  std::vector<char> visited(num_nodes, 0);
  std::queue<int> queue;
  queue.push(reference_node);
  visited[reference_node] = 1;
  int num_visited = 1;
  while (!queue.empty()) {
    const int node = queue.front();
    queue.pop();
    for (const size_t edge_idx : tree_edges[node]) {
      const RelativeRotation& edge = relative_rotations[edge_idx];
      const int other = edge.node1 == node ? edge.node2 : edge.node1;
      if (visited[other]) {
        continue;
      }
      // R_2 = R_12 R_1.
      (*rotations)[other] =
          edge.node1 == node
              ? (edge.rotation * (*rotations)[node]).normalized()
              : (edge.rotation.inverse() * (*rotations)[node]).normalized();
      visited[other] = 1;
      ++num_visited;
      queue.push(other);
    }
  }
  return num_visited == num_nodes;
}

// Linearisation around the current rotations: one 3-row block per edge,
//   x_node2 - x_node1 = log(R_2^T R_12 R_1),
// with the reference node's columns left out. The matrix depends on the
// graph alone; the right-hand side on the current rotations.
Eigen::SparseMatrix<double> LinearSystemMatrix(
    const int num_nodes,
    const std::vector<RelativeRotation>& relative_rotations,
    const int reference_node) {
  auto column = [reference_node](int node) {
    return node < reference_node ? node : node - 1;
  };
  std::vector<Eigen::Triplet<double>> triplets;
  for (size_t e = 0; e < relative_rotations.size(); ++e) {
    const RelativeRotation& edge = relative_rotations[e];
    for (int d = 0; d < 3; ++d) {
      if (edge.node2 != reference_node) {
        triplets.emplace_back(3 * e + d, 3 * column(edge.node2) + d, 1.0);
      }
      if (edge.node1 != reference_node) {
        triplets.emplace_back(3 * e + d, 3 * column(edge.node1) + d, -1.0);
      }
    }
  }
  Eigen::SparseMatrix<double> A(3 * relative_rotations.size(),
                                3 * (num_nodes - 1));
  A.setFromTriplets(triplets.begin(), triplets.end());
  return A;
}

Eigen::VectorXd LinearSystemResiduals(
    const std::vector<RelativeRotation>& relative_rotations,
    const std::vector<Eigen::Quaterniond>& rotations) {
  Eigen::VectorXd b(3 * relative_rotations.size());
  for (size_t e = 0; e < relative_rotations.size(); ++e) {
    const RelativeRotation& edge = relative_rotations[e];
    const Eigen::Quaterniond residual =
        rotations[edge.node2].inverse() * edge.rotation * rotations[edge.node1];
    b.segment<3>(3 * e) = RotationToAngleAxis(residual);
  }
  return b;
}

// Applies R_k <- R_k exp(x_k) and returns the largest update angle.
double ApplyUpdate(const Eigen::VectorXd& x,
                   const int reference_node,
                   std::vector<Eigen::Quaterniond>* rotations) {
  double max_step = 0;
  for (int node = 0; node < static_cast<int>(rotations->size()); ++node) {
    if (node == reference_node) {
      continue;
    }
    const int col = node < reference_node ? node : node - 1;
    const Eigen::Vector3d step = x.segment<3>(3 * col);
    (*rotations)[node] =
        ((*rotations)[node] * AngleAxisToRotation(step)).normalized();
    max_step = std::max(max_step, step.norm());
  }
  return max_step;
}

}  // namespace

bool AverageRotations(int num_nodes,
                      const std::vector<RelativeRotation>& relative_rotations,
                      int reference_node,
                      std::vector<Eigen::Quaterniond>* rotations) {
  constexpr int kMaxNumL1Iterations = 30;
  constexpr double kL1StepTolerance = 1e-9;
  constexpr int kMaxNumIrlsIterations = 50;
  constexpr double kIrlsStepTolerance = 1e-12;
  constexpr double kIrlsSigmaDeg = 5.0;
  THROW_CHECK_GT(num_nodes, 0);
  THROW_CHECK_GE(reference_node, 0);
  THROW_CHECK_LT(reference_node, num_nodes);
  THROW_CHECK_NOTNULL(rotations);
  for (const RelativeRotation& edge : relative_rotations) {
    THROW_CHECK_GE(edge.node1, 0);
    THROW_CHECK_LT(edge.node1, num_nodes);
    THROW_CHECK_GE(edge.node2, 0);
    THROW_CHECK_LT(edge.node2, num_nodes);
    THROW_CHECK_NE(edge.node1, edge.node2);
    THROW_CHECK_GT(edge.weight, 0);
  }

  if (!InitializeFromSpanningTree(
          num_nodes, relative_rotations, reference_node, rotations)) {
    return false;
  }
  if (num_nodes == 1) {
    return true;
  }

  const Eigen::SparseMatrix<double> A =
      LinearSystemMatrix(num_nodes, relative_rotations, reference_node);
  // Per row: the confidence of its edge, relative to the largest.
  Eigen::VectorXd confidence(3 * relative_rotations.size());
  for (size_t e = 0; e < relative_rotations.size(); ++e) {
    confidence.segment<3>(3 * e).setConstant(relative_rotations[e].weight);
  }
  confidence /= confidence.maxCoeff();

  // L1RA: the weighted matrix is factorised once for all iterations.
  {
    LeastAbsoluteDeviationSolver::Options l1_options;
    l1_options.max_num_iterations = 5000;
    l1_options.absolute_tolerance = 1e-10;
    l1_options.relative_tolerance = 1e-8;
    const Eigen::SparseMatrix<double> weighted_A = confidence.asDiagonal() * A;
    const LeastAbsoluteDeviationSolver l1_solver(l1_options, weighted_A);
    for (int iter = 0; iter < kMaxNumL1Iterations; ++iter) {
      const Eigen::VectorXd weighted_b =
          confidence.asDiagonal() *
          LinearSystemResiduals(relative_rotations, *rotations);
      Eigen::VectorXd x = Eigen::VectorXd::Zero(A.cols());
      if (!l1_solver.Solve(weighted_b, &x)) {
        return false;
      }
      if (ApplyUpdate(x, reference_node, rotations) < kL1StepTolerance) {
        break;
      }
    }
  }

  // IRLS with Geman-McClure weights.
  const double sigma = DegToRad(kIrlsSigmaDeg);
  const double sigma_sq = sigma * sigma;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  for (int iter = 0; iter < kMaxNumIrlsIterations; ++iter) {
    const Eigen::VectorXd b =
        LinearSystemResiduals(relative_rotations, *rotations);
    Eigen::VectorXd weights(A.rows());
    for (size_t e = 0; e < relative_rotations.size(); ++e) {
      const double denominator = b.segment<3>(3 * e).squaredNorm() + sigma_sq;
      weights.segment<3>(3 * e).setConstant(confidence(3 * e) * sigma_sq /
                                            (denominator * denominator));
    }
    const Eigen::SparseMatrix<double> At_W =
        A.transpose() * weights.asDiagonal();
    const Eigen::SparseMatrix<double> normal_matrix = At_W * A;
    if (iter == 0) {
      solver.analyzePattern(normal_matrix);
    }
    solver.factorize(normal_matrix);
    if (solver.info() != Eigen::Success) {
      return false;
    }
    const Eigen::VectorXd x = solver.solve(At_W * b);
    if (solver.info() != Eigen::Success) {
      return false;
    }
    if (ApplyUpdate(x, reference_node, rotations) < kIrlsStepTolerance) {
      break;
    }
  }

  return true;
}

}  // namespace colmap
