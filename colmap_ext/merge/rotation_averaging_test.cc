#include "colmap_ext/merge/rotation_averaging.h"

#include "colmap/math/math.h"

#include <random>

#include <gtest/gtest.h>

namespace colmap {
namespace {

Eigen::Quaterniond RandomRotation(std::mt19937* rng, double max_angle_deg) {
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> uniform(0, 1);
  const Eigen::Vector3d axis =
      Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)).normalized();
  return Eigen::Quaterniond(
      Eigen::AngleAxisd(DegToRad(max_angle_deg) * uniform(*rng), axis));
}

// Angle (degrees) between R_ij and R_j R_i^T.
double RelativeRotationResidualDeg(
    const RelativeRotation& relative_rotation,
    const std::vector<Eigen::Quaterniond>& rotations) {
  const Eigen::Quaterniond predicted =
      rotations[relative_rotation.node2] *
      rotations[relative_rotation.node1].inverse();
  return RadToDeg(predicted.angularDistance(relative_rotation.rotation));
}

struct Problem {
  std::vector<Eigen::Quaterniond> truth;
  std::vector<RelativeRotation> edges;
  std::vector<bool> is_outlier;
};

// A connected graph: a ring plus random chords, R_ij = R_j R_i^T, with
// noise, and the given fraction of edges replaced by random rotations.
Problem MakeProblem(const int num_nodes,
                    const int num_chords,
                    const double noise_deg,
                    const double outlier_ratio,
                    const unsigned seed) {
  std::mt19937 rng(seed);
  Problem problem;
  for (int i = 0; i < num_nodes; ++i) {
    problem.truth.push_back(RandomRotation(&rng, 180));
  }
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < num_nodes; ++i) {
    pairs.emplace_back(i, (i + 1) % num_nodes);
  }
  std::uniform_int_distribution<int> node(0, num_nodes - 1);
  while (static_cast<int>(pairs.size()) < num_nodes + num_chords) {
    const int i = node(rng);
    const int j = node(rng);
    if (i != j) {
      pairs.emplace_back(i, j);
    }
  }
  std::uniform_real_distribution<double> uniform(0, 1);
  for (const auto& pair : pairs) {
    RelativeRotation edge;
    edge.node1 = pair.first;
    edge.node2 = pair.second;
    const bool outlier = uniform(rng) < outlier_ratio;
    edge.rotation = outlier ? RandomRotation(&rng, 180)
                            : RandomRotation(&rng, noise_deg) *
                                  problem.truth[pair.second] *
                                  problem.truth[pair.first].inverse();
    edge.weight = outlier ? 1.0 : 2.0;
    problem.edges.push_back(edge);
    problem.is_outlier.push_back(outlier);
  }
  return problem;
}

// Largest angle between estimated and true rotations, after fixing the
// gauge at node 0 (estimates have R_0 = I).
double MaxErrorDeg(const std::vector<Eigen::Quaterniond>& estimated,
                   const std::vector<Eigen::Quaterniond>& truth) {
  double max_error = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const Eigen::Quaterniond aligned = truth[i] * truth[0].inverse();
    max_error =
        std::max(max_error, RadToDeg(estimated[i].angularDistance(aligned)));
  }
  return max_error;
}

TEST(AverageRotations, NoiselessIsExact) {
  const Problem problem = MakeProblem(20, 30, /*noise_deg=*/0, 0, 1);
  std::vector<Eigen::Quaterniond> rotations;
  ASSERT_TRUE(AverageRotations(
      20, problem.edges, 0, &rotations));
  EXPECT_LT(MaxErrorDeg(rotations, problem.truth), 1e-6);
  EXPECT_LT(rotations[0].angularDistance(Eigen::Quaterniond::Identity()),
            1e-12);
}

TEST(AverageRotations, NoisyStaysWithinNoiseLevel) {
  const Problem problem = MakeProblem(30, 60, /*noise_deg=*/1.0, 0, 2);
  std::vector<Eigen::Quaterniond> rotations;
  ASSERT_TRUE(AverageRotations(
      30, problem.edges, 0, &rotations));
  EXPECT_LT(MaxErrorDeg(rotations, problem.truth), 1.0);
}

TEST(AverageRotations, RobustToWrongEdges) {
  const Problem problem = MakeProblem(30, 90, /*noise_deg=*/0.5, 0.2, 3);
  std::vector<Eigen::Quaterniond> rotations;
  ASSERT_TRUE(AverageRotations(
      30, problem.edges, 0, &rotations));
  EXPECT_LT(MaxErrorDeg(rotations, problem.truth), 1.0);
  // Residuals separate the wrong edges from the right ones.
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    const double residual =
        RelativeRotationResidualDeg(problem.edges[e], rotations);
    if (problem.is_outlier[e]) {
      EXPECT_GT(residual, 5.0);
    } else {
      EXPECT_LT(residual, 2.0);
    }
  }
}

TEST(AverageRotations, NonZeroReferenceNode) {
  const Problem problem = MakeProblem(10, 10, 0, 0, 4);
  std::vector<Eigen::Quaterniond> rotations;
  ASSERT_TRUE(AverageRotations(
      10, problem.edges, 7, &rotations));
  EXPECT_LT(rotations[7].angularDistance(Eigen::Quaterniond::Identity()),
            1e-12);
  for (int i = 0; i < 10; ++i) {
    const Eigen::Quaterniond aligned =
        problem.truth[i] * problem.truth[7].inverse();
    EXPECT_LT(RadToDeg(rotations[i].angularDistance(aligned)), 1e-6);
  }
}

TEST(AverageRotations, DisconnectedGraphFails) {
  std::vector<RelativeRotation> edges(1);
  edges[0].node1 = 0;
  edges[0].node2 = 1;
  std::vector<Eigen::Quaterniond> rotations;
  EXPECT_FALSE(
      AverageRotations(3, edges, 0, &rotations));
}

}  // namespace
}  // namespace colmap
