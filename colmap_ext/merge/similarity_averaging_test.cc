#include "colmap_ext/merge/similarity_averaging.h"

#include "colmap/math/math.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

namespace colmap {
namespace {

Eigen::Quaterniond RandomRotation(std::mt19937* rng) {
  std::normal_distribution<double> normal(0, 1);
  return Eigen::Quaterniond(
             normal(*rng), normal(*rng), normal(*rng), normal(*rng))
      .normalized();
}

Sim3d RandomSim3(std::mt19937* rng) {
  std::uniform_real_distribution<double> log_scale(std::log(0.2),
                                                   std::log(5.0));
  std::normal_distribution<double> normal(0, 20);
  return Sim3d(std::exp(log_scale(*rng)),
               RandomRotation(rng),
               Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)));
}

struct Problem {
  std::vector<Sim3d> world_from_community;
  std::vector<RelativeSimilarity> edges;
  std::vector<bool> is_outlier;
  std::vector<int> sizes;

  std::vector<AveragedCommunity> Communities() const {
    std::vector<AveragedCommunity> communities(sizes.size());
    for (size_t c = 0; c < sizes.size(); ++c) {
      communities[c].num_images = sizes[c];
    }
    return communities;
  }
};

struct Noise {
  double rotation_deg = 0;
  double log_scale = 0;
  // Standard deviation of the correspondences' noise, in the world frame.
  double point = 0;
};

// Communities on a ring, each joined to its next three, plus random chords.
// Each edge has 40 world points (within 10 units of the communities' pair
// midpoint) seen in both communities' frames, and reports full support (100
// inliers: a bridge needs no shared images to confirm it). A fraction of the
// edges, at random but at most a third of any community's edges (L1 needs a
// majority of right edges around every community), get a random similarity,
// their points moved consistently with it.
Problem MakeProblem(const int num_communities,
                    const int num_chords,
                    const Noise& noise,
                    const double outlier_ratio,
                    const unsigned seed) {
  std::mt19937 rng(seed);
  Problem problem;
  for (int i = 0; i < num_communities; ++i) {
    problem.world_from_community.push_back(RandomSim3(&rng));
    problem.sizes.push_back(10 + i);
  }
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < num_communities; ++i) {
    for (int step = 1; step <= std::min(3, num_communities / 2); ++step) {
      pairs.emplace_back(i, (i + step) % num_communities);
    }
  }
  std::uniform_int_distribution<int> community(0, num_communities - 1);
  for (int chord = 0; chord < num_chords;) {
    const int i = community(rng);
    const int j = community(rng);
    if (i != j) {
      pairs.emplace_back(i, j);
      ++chord;
    }
  }

  std::vector<int> degree(num_communities, 0);
  for (const auto& pair : pairs) {
    ++degree[pair.first];
    ++degree[pair.second];
  }
  std::vector<size_t> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<bool> is_outlier(pairs.size(), false);
  std::vector<int> num_outliers(num_communities, 0);
  const int target = static_cast<int>(outlier_ratio * pairs.size());
  int num_chosen = 0;
  for (const size_t e : order) {
    const int i = pairs[e].first;
    const int j = pairs[e].second;
    if (num_chosen < target && 3 * (num_outliers[i] + 1) <= degree[i] &&
        3 * (num_outliers[j] + 1) <= degree[j]) {
      is_outlier[e] = true;
      ++num_outliers[i];
      ++num_outliers[j];
      ++num_chosen;
    }
  }

  std::normal_distribution<double> unit_normal(0, 1);
  for (size_t e = 0; e < pairs.size(); ++e) {
    const auto& pair = pairs[e];
    const Sim3d& world_from_1 = problem.world_from_community[pair.first];
    const Sim3d& world_from_2 = problem.world_from_community[pair.second];
    RelativeSimilarity edge;
    edge.community1 = pair.first;
    edge.community2 = pair.second;
    edge.num_inliers = 100;
    const bool outlier = is_outlier[e];
    const Eigen::Vector3d center =
        0.5 * (world_from_1.translation() + world_from_2.translation());
    for (int k = 0; k < 40; ++k) {
      const Eigen::Vector3d world_point =
          center + 10 * Eigen::Vector3d(unit_normal(rng),
                                        unit_normal(rng),
                                        unit_normal(rng));
      const Eigen::Vector3d noisy =
          world_point + noise.point * Eigen::Vector3d(unit_normal(rng),
                                                      unit_normal(rng),
                                                      unit_normal(rng));
      edge.points1.push_back(Inverse(world_from_1) * world_point);
      edge.points2.push_back(Inverse(world_from_2) * noisy);
    }
    if (outlier) {
      edge.second_from_first = RandomSim3(&rng);
      for (size_t k = 0; k < edge.points1.size(); ++k) {
        edge.points2[k] = edge.second_from_first * edge.points1[k];
      }
    } else {
      // X2 = (world_from_2)^-1 world_from_1 X1, then perturbed.
      edge.second_from_first = Inverse(world_from_2) * world_from_1;
      edge.second_from_first.scale() *=
          std::exp(noise.log_scale * unit_normal(rng));
      edge.second_from_first.rotation() =
          Eigen::Quaterniond(Eigen::AngleAxisd(
              DegToRad(noise.rotation_deg) * unit_normal(rng),
              Eigen::Vector3d(
                  unit_normal(rng), unit_normal(rng), unit_normal(rng))
                  .normalized())) *
          edge.second_from_first.rotation();
    }
    problem.edges.push_back(edge);
    problem.is_outlier.push_back(outlier);
  }
  return problem;
}

struct Errors {
  double rotation_deg = 0;
  double log_scale = 0;
  // Of the communities' origins in the world frame.
  double position = 0;
};

// Largest errors after fixing the gauge: the estimate has the reference
// (largest) community at identity, so compare with truth_ref^-1 * truth_i.
Errors MaxErrors(const SimilarityAveragingResult& result,
                 const Problem& problem) {
  const int reference = static_cast<int>(
      std::max_element(problem.sizes.begin(), problem.sizes.end()) -
      problem.sizes.begin());
  const Sim3d gauge = Inverse(problem.world_from_community[reference]);
  Errors errors;
  for (size_t i = 0; i < problem.world_from_community.size(); ++i) {
    const Sim3d truth = gauge * problem.world_from_community[i];
    const Sim3d& estimate = result.world_from_community[i];
    errors.rotation_deg = std::max(
        errors.rotation_deg,
        RadToDeg(estimate.rotation().angularDistance(truth.rotation())));
    errors.log_scale = std::max(
        errors.log_scale, std::abs(std::log(estimate.scale() / truth.scale())));
    errors.position = std::max(
        errors.position, (estimate.translation() - truth.translation()).norm());
  }
  return errors;
}

// No bound: every edge on a cycle is kept.
SimilarityAveragingOptions NoRejection() {
  SimilarityAveragingOptions options;
  options.max_relative_displacement = std::numeric_limits<double>::infinity();
  return options;
}

TEST(AverageSimilarities, NoiselessInputIsRecoveredExactly) {
  for (const int num_communities : {10, 20, 30}) {
    const Problem problem = MakeProblem(num_communities, 5, Noise(), 0, 10);
    const SimilarityAveragingResult result = AverageSimilarities(
        problem.Communities(), problem.edges, SimilarityAveragingOptions());
    EXPECT_EQ(result.NumParts(), 1);
    const Errors errors = MaxErrors(result, problem);
    EXPECT_LT(errors.rotation_deg, 1e-6) << num_communities;
    EXPECT_LT(errors.log_scale, 1e-7) << num_communities;
    // The reference frame's scale is up to 5x that of the truth's unit.
    EXPECT_LT(errors.position, 1e-5) << num_communities;
    for (const auto& edge : result.edges) {
      EXPECT_TRUE(edge.kept);
    }
  }
}

TEST(AverageSimilarities, NoisyInputStaysWithinBound) {
  Noise noise;
  noise.rotation_deg = 0.5;
  noise.log_scale = 0.01;
  noise.point = 0.1;  // 1% of the points' spread
  const Problem problem = MakeProblem(20, 10, noise, 0, 11);
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_EQ(result.NumParts(), 1);
  const Errors errors = MaxErrors(result, problem);
  // Bounds: three times the per-edge noise (errors accumulate over a few
  // edges).
  EXPECT_LT(errors.rotation_deg, 1.5);
  EXPECT_LT(errors.log_scale, 0.03);
  // Positions: within 2% of the spread of the communities (~20 units
  // around each, up to 5x scaled).
  EXPECT_LT(errors.position, 2.0);
  for (const auto& edge : result.edges) {
    EXPECT_TRUE(edge.kept);
  }
}

TEST(AverageSimilarities, L1RecoversTruthWithWrongEdges) {
  Noise noise;
  noise.rotation_deg = 0.2;
  noise.log_scale = 0.005;
  const Problem problem = MakeProblem(25, 25, noise, 0.2, 12);
  int num_outliers = 0;
  for (const bool outlier : problem.is_outlier) {
    num_outliers += outlier;
  }
  // 20% of the edges are wrong.
  ASSERT_EQ(num_outliers, 20);

  // Without rejection, so that the solver alone is judged.
  const Errors l1 = MaxErrors(
      AverageSimilarities(problem.Communities(), problem.edges, NoRejection()),
      problem);
  // Within a few times the right edges' noise (0.2 deg, 0.005 in log
  // scale), as without wrong edges.
  EXPECT_LT(l1.rotation_deg, 0.6);
  EXPECT_LT(l1.log_scale, 0.02);
  EXPECT_LT(l1.position, 2.0);
}

TEST(AverageSimilarities, WrongEdgesAreReportedAndDropped) {
  Noise noise;
  noise.rotation_deg = 0.2;
  noise.log_scale = 0.005;
  noise.point = 0.05;
  const Problem problem = MakeProblem(25, 25, noise, 0.2, 13);
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_EQ(result.NumParts(), 1);
  int num_dropped_inliers = 0;
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    if (problem.is_outlier[e]) {
      EXPECT_FALSE(result.edges[e].kept) << e;
    } else {
      num_dropped_inliers += !result.edges[e].kept;
    }
  }
  EXPECT_LE(num_dropped_inliers, 3);
  const Errors errors = MaxErrors(result, problem);
  EXPECT_LT(errors.rotation_deg, 0.6);
  EXPECT_LT(errors.log_scale, 0.02);
  EXPECT_LT(errors.position, 2.0);
}

TEST(AverageSimilarities, UnconnectedCommunitiesFormSeparateParts) {
  // Communities 0-1-2 and 3-4, no edge between the groups.
  Problem problem = MakeProblem(5, 0, Noise(), 0, 14);
  std::vector<RelativeSimilarity> edges;
  for (const RelativeSimilarity& edge : problem.edges) {
    const bool first_group = edge.community1 < 3 && edge.community2 < 3;
    const bool second_group = edge.community1 >= 3 && edge.community2 >= 3;
    if (first_group || second_group) {
      edges.push_back(edge);
    }
  }
  problem.sizes = {10, 10, 10, 50, 5};
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), edges, SimilarityAveragingOptions());
  ASSERT_EQ(result.NumParts(), 2);
  // Parts by total size: {3, 4} has 55 images, {0, 1, 2} has 30.
  EXPECT_EQ(result.part_of_community, (std::vector<int>{1, 1, 1, 0, 0}));
  // Each part's largest community is its reference.
  EXPECT_LT(result.world_from_community[3].translation().norm(), 1e-12);
  EXPECT_NEAR(result.world_from_community[3].scale(), 1.0, 1e-12);
  EXPECT_LT(result.world_from_community[0].translation().norm(), 1e-12);
}

TEST(AverageSimilarities, EdgeWithoutItsPointsIsRefused) {
  // An edge is judged by where the averaging puts its inlier points.
  Problem problem = MakeProblem(8, 4, Noise(), 0, 15);
  problem.edges[0].points1.clear();
  problem.edges[0].points2.clear();
  EXPECT_ANY_THROW(AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions()));
}

// A single cycle of five communities (no chords): L1 alone cannot tell
// which edge is wrong when the cycle does not close.
Problem MakeCycle(const std::vector<int>& sizes, const unsigned seed) {
  Problem ring =
      MakeProblem(static_cast<int>(sizes.size()), 0, Noise(), 0, seed);
  Problem cycle = ring;
  cycle.edges.clear();
  cycle.is_outlier.clear();
  for (size_t e = 0; e < ring.edges.size(); ++e) {
    const int step = (ring.edges[e].community2 - ring.edges[e].community1 +
                      static_cast<int>(sizes.size())) %
                     static_cast<int>(sizes.size());
    if (step == 1) {
      cycle.edges.push_back(ring.edges[e]);
      cycle.is_outlier.push_back(false);
    }
  }
  cycle.sizes = sizes;
  return cycle;
}

// Turns and moves `community`'s side of `edge` by `bend`, as if its model
// had been misplaced where the two overlap.
void MisplaceSide(const int community,
                  const Sim3d& bend,
                  RelativeSimilarity* edge) {
  if (edge->community2 == community) {
    edge->second_from_first = bend * edge->second_from_first;
    for (Eigen::Vector3d& point : edge->points2) {
      point = bend * point;
    }
  } else {
    edge->second_from_first = edge->second_from_first * Inverse(bend);
    for (Eigen::Vector3d& point : edge->points1) {
      point = bend * point;
    }
  }
}

// Bends the edge's similarity (as a community that broke inside itself
// bends the transform seen from its far side): 25 degrees and 60% in scale,
// about what a broken walkway community did to a generated courtyard loop
// (the pairwise similarities around it multiplied to a rotation of 52
// degrees and a scale of 2.1).
void Bend(RelativeSimilarity* edge) {
  const Sim3d bend(1.6,
                   Eigen::Quaterniond(Eigen::AngleAxisd(
                       DegToRad(25.0), Eigen::Vector3d::UnitY())),
                   Eigen::Vector3d::Zero());
  MisplaceSide(edge->community2, bend, edge);
}

int FindEdge(const Problem& problem,
             const int community1,
             const int community2) {
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    if (std::minmax(problem.edges[e].community1, problem.edges[e].community2) ==
        std::minmax(community1, community2)) {
      return static_cast<int>(e);
    }
  }
  return -1;
}

// A cycle (MakeCycle) whose edge between `community1` and `community2` is
// bent (Bend); `bent`, if given, receives that edge's index.
Problem MakeBentCycle(const std::vector<int>& sizes,
                      const unsigned seed,
                      const int community1,
                      const int community2,
                      int* bent = nullptr) {
  Problem problem = MakeCycle(sizes, seed);
  const int edge = FindEdge(problem, community1, community2);
  THROW_CHECK_GE(edge, 0);
  Bend(&problem.edges[edge]);
  if (bent != nullptr) {
    *bent = edge;
  }
  return problem;
}

TEST(AverageSimilarities, CommunitiesOfACycleThatDoesNotCloseStayWhole) {
  // The edge between communities 1 and 2 is bent and nothing else tells
  // which edge is wrong: the cycle's disagreement drops one edge (the
  // lightest), and every community stays, joined by the others in one part
  // (a community is judged by its edges, not sent out of the merge for one
  // disagreement).
  const Problem problem = MakeBentCycle({150, 120, 110, 130, 100}, 22, 1, 2);
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  int num_dropped = 0;
  for (const auto& edge : result.edges) {
    num_dropped += edge.kept ? 0 : 1;
  }
  EXPECT_EQ(num_dropped, 1);
  EXPECT_EQ(result.NumParts(), 1);
}

TEST(AverageSimilarities, BridgeNeedsItsSharedImages) {
  // A path 0 - 1 - 2 of three communities: no cycle checks any edge.
  Problem problem = MakeCycle({150, 120, 110}, 23);
  std::vector<RelativeSimilarity> path;
  for (const RelativeSimilarity& edge : problem.edges) {
    if (std::max(edge.community1, edge.community2) -
            std::min(edge.community1, edge.community2) ==
        1) {
      path.push_back(edge);
    }
  }
  ASSERT_EQ(path.size(), 2);
  for (RelativeSimilarity& edge : path) {
    edge.num_shared_images = 6;
    edge.num_agreeing_shared_images = 6;
  }
  const std::vector<AveragedCommunity> communities = problem.Communities();
  // Confirmed by all their shared images: one part.
  EXPECT_EQ(AverageSimilarities(communities, path, SimilarityAveragingOptions())
                .NumParts(),
            1);

  // 3 of the 6 images communities 1 and 2 share placed elsewhere: they
  // contradict that edge, which goes, and community 2 stands alone.
  const int edge12 =
      std::max(path[0].community1, path[0].community2) == 2 ? 0 : 1;
  path[edge12].num_agreeing_shared_images = 3;
  SimilarityAveragingResult result =
      AverageSimilarities(communities, path, SimilarityAveragingOptions());
  EXPECT_FALSE(result.edges[edge12].kept);
  EXPECT_TRUE(result.edges[edge12].contradicted);
  EXPECT_TRUE(result.edges[1 - edge12].kept);
  EXPECT_EQ(result.NumParts(), 2);
  EXPECT_EQ(result.part_of_community[0], result.part_of_community[1]);
  EXPECT_NE(result.part_of_community[2], result.part_of_community[0]);

  // One or two of the 6 placed elsewhere (borrowed images at the edge of a
  // drifting community), the others alike: the edge stays, one part; as
  // many elsewhere as alike veto it, even with full support.
  for (const int num_agreeing : {5, 4}) {
    path[edge12].num_agreeing_shared_images = num_agreeing;
    result =
        AverageSimilarities(communities, path, SimilarityAveragingOptions());
    EXPECT_TRUE(result.edges[edge12].kept) << num_agreeing;
    EXPECT_EQ(result.NumParts(), 1) << num_agreeing;
  }
  path[edge12].num_agreeing_shared_images = 3;
  path[edge12].num_inliers = 500;
  EXPECT_EQ(AverageSimilarities(communities, path, SimilarityAveragingOptions())
                .NumParts(),
            2);

  // Too few shared images and weak support on both edges: nothing confirms
  // them, three parts, and no community is sent out of the merge for it.
  for (RelativeSimilarity& edge : path) {
    edge.num_shared_images = 1;
    edge.num_agreeing_shared_images = 1;
    edge.num_inliers = 50;
  }
  result = AverageSimilarities(communities, path, SimilarityAveragingOptions());
  EXPECT_TRUE(result.edges[0].unconfirmed);
  EXPECT_TRUE(result.edges[1].unconfirmed);
  EXPECT_EQ(result.NumParts(), 3);

  // On a cycle, the residuals check the edges instead.
  std::vector<RelativeSimilarity> cycle = problem.edges;
  ASSERT_EQ(cycle.size(), 3);
  for (RelativeSimilarity& edge : cycle) {
    edge.num_inliers = 50;
  }
  result =
      AverageSimilarities(communities, cycle, SimilarityAveragingOptions());
  EXPECT_EQ(result.NumParts(), 1);
}

// Shared images that contradict an edge leave it out before the averaging,
// on a cycle too: two edges wrong alike around one community outweigh its
// right one in the averaging, and would place it wrong.
TEST(AverageSimilarities, EdgesTheirSharedImagesContradictAreLeftOut) {
  // Four communities, every pair linked; the links of community 2 to 0 and
  // 1 place it turned by 40 degrees and moved, the rest are right.
  Problem problem = MakeProblem(4, 0, Noise(), 0, 31);
  std::vector<RelativeSimilarity> edges;
  for (const RelativeSimilarity& edge : problem.edges) {
    if (FindEdge(Problem{{}, edges, {}, {}}, edge.community1, edge.community2) <
        0) {
      edges.push_back(edge);
    }
  }
  problem.edges = edges;
  ASSERT_EQ(problem.edges.size(), 6);
  const Sim3d bend(1.0,
                   Eigen::Quaterniond(Eigen::AngleAxisd(
                       DegToRad(40.0), Eigen::Vector3d::UnitZ())),
                   Eigen::Vector3d(5, 0, 0));
  std::vector<bool> wrong(problem.edges.size(), false);
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    RelativeSimilarity& edge = problem.edges[e];
    edge.num_shared_images = 6;
    edge.num_agreeing_shared_images = 6;
    const int other = edge.community1 == 2
                          ? edge.community2
                          : (edge.community2 == 2 ? edge.community1 : -1);
    if (other == 0 || other == 1) {
      MisplaceSide(2, bend, &edge);
      edge.num_agreeing_shared_images = 2;
      wrong[e] = true;
    }
  }
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_EQ(result.NumParts(), 1);
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    EXPECT_EQ(result.edges[e].contradicted, wrong[e]) << e;
    EXPECT_EQ(result.edges[e].kept, !wrong[e]) << e;
  }
  EXPECT_LT(MaxErrors(result, problem).rotation_deg, 1e-3);

  // Placed alike by their shared images, the two wrong edges outweigh the
  // right one: community 2 follows them, and its right edge leaves instead.
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    problem.edges[e].num_agreeing_shared_images = 6;
  }
  const SimilarityAveragingResult unvetoed = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_GT(MaxErrors(unvetoed, problem).rotation_deg, 10.0);
}

// Every edge of `problem` but `bent` kept, and every community in one part
// where it belongs.
void ExpectAlignedWithoutEdge(const SimilarityAveragingResult& result,
                              const Problem& problem,
                              const int bent) {
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    EXPECT_EQ(result.edges[e].kept, static_cast<int>(e) != bent) << e;
  }
  EXPECT_EQ(result.NumParts(), 1);
  const Errors errors = MaxErrors(result, problem);
  EXPECT_LT(errors.rotation_deg, 1e-6);
  EXPECT_LT(errors.position, 1e-5);
}

// As on one matching of South Building: community 0 (its mapper broke it
// into two models) had one right link confirmed by its 6 shared images and
// two wrong ones, weakly supported, flipped by 176 and 179 degrees (a
// symmetric facade).
TEST(AverageSimilarities, FlippedEdgesGoAndARightEdgeKeepsItsCommunity) {
  Problem problem = MakeCycle({40, 39, 31, 15}, 40);
  const Problem complete = MakeProblem(4, 0, Noise(), 0, 40);
  const int edge02 = FindEdge(complete, 0, 2);
  ASSERT_GE(edge02, 0);
  problem.edges.push_back(complete.edges[edge02]);
  const int wrong02 = static_cast<int>(problem.edges.size()) - 1;
  const int wrong03 = FindEdge(problem, 0, 3);
  const auto flip = [](RelativeSimilarity* edge,
                       const double angle_deg,
                       const Eigen::Vector3d& axis) {
    const Sim3d wrong(1.1,
                      Eigen::Quaterniond(Eigen::AngleAxisd(DegToRad(angle_deg),
                                                           axis.normalized())),
                      Eigen::Vector3d(3, 0, 0));
    edge->second_from_first = wrong * edge->second_from_first;
    for (Eigen::Vector3d& point : edge->points2) {
      point = wrong * point;
    }
  };
  flip(&problem.edges[wrong02], 170, Eigen::Vector3d(1, 0, 0));
  problem.edges[wrong02].num_inliers = 22;
  flip(&problem.edges[wrong03], 175, Eigen::Vector3d(0, 1, 0.3));
  problem.edges[wrong03].num_inliers = 48;
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    if (static_cast<int>(e) != wrong02 && static_cast<int>(e) != wrong03) {
      problem.edges[e].num_shared_images = 6;
      problem.edges[e].num_agreeing_shared_images = 6;
    }
  }
  const std::vector<AveragedCommunity> communities = problem.Communities();

  const SimilarityAveragingResult result = AverageSimilarities(
      communities, problem.edges, SimilarityAveragingOptions());
  EXPECT_FALSE(result.edges[wrong02].kept);
  EXPECT_FALSE(result.edges[wrong03].kept);
  EXPECT_TRUE(result.edges[FindEdge(problem, 0, 1)].kept);
  EXPECT_TRUE(result.edges[FindEdge(problem, 1, 2)].kept);
  EXPECT_EQ(result.part_of_community[0], result.part_of_community[1]);
  EXPECT_EQ(result.part_of_community[2], result.part_of_community[1]);
  const Sim3d gauge = Inverse(problem.world_from_community[0]);
  for (const int c : {1, 2}) {
    const Sim3d truth = gauge * problem.world_from_community[c];
    EXPECT_LT(
        RadToDeg(result.world_from_community[c].rotation().angularDistance(
            truth.rotation())),
        1e-6)
        << c;
  }
}

TEST(AverageSimilarities, BridgeWithoutSharedImagesNeedsFullSupport) {
  // A path 0 - 1 - 2 of sound communities; the edge 1-2 has no shared image
  // (its borrowed images were not registered), as a link made only of wrong
  // matches between similar facades had on a subset of South Building.
  Problem problem = MakeCycle({150, 120, 110}, 29);
  std::vector<RelativeSimilarity> path;
  for (const RelativeSimilarity& edge : problem.edges) {
    if (std::abs(edge.community1 - edge.community2) == 1) {
      path.push_back(edge);
      path.back().num_shared_images = 6;
      path.back().num_agreeing_shared_images = 6;
    }
  }
  ASSERT_EQ(path.size(), 2);
  const int edge12 =
      std::max(path[0].community1, path[0].community2) == 2 ? 0 : 1;
  path[edge12].num_shared_images = 0;
  path[edge12].num_agreeing_shared_images = 0;
  std::vector<AveragedCommunity> communities = problem.Communities();
  const SimilarityAveragingOptions options;

  // 25 inliers, but 6 shared images placed alike, or 2 alike and 1 not:
  // confirmed.
  path[edge12].num_inliers = 25;
  path[edge12].num_shared_images = 6;
  path[edge12].num_agreeing_shared_images = 6;
  EXPECT_EQ(AverageSimilarities(communities, path, options).NumParts(), 1);
  path[edge12].num_shared_images = 3;
  path[edge12].num_agreeing_shared_images = 2;
  EXPECT_EQ(AverageSimilarities(communities, path, options).NumParts(), 1);
  path[edge12].num_shared_images = 0;
  path[edge12].num_agreeing_shared_images = 0;

  // 25 inliers and no shared image: nothing confirms it, two models rather
  // than a wrong one.
  path[edge12].num_inliers = 25;
  SimilarityAveragingResult result =
      AverageSimilarities(communities, path, options);
  EXPECT_FALSE(result.edges[edge12].kept);
  EXPECT_TRUE(result.edges[edge12].unconfirmed);
  EXPECT_TRUE(result.edges[1 - edge12].kept);
  EXPECT_EQ(result.NumParts(), 2);
  EXPECT_NE(result.part_of_community[2], result.part_of_community[1]);

  // Full support stands in for the shared images.
  path[edge12].num_inliers = kFullSupportNumInliers;
  result = AverageSimilarities(communities, path, options);
  EXPECT_TRUE(result.edges[edge12].kept);
  EXPECT_EQ(result.NumParts(), 1);

  // On a cycle, the residuals check it instead.
  std::vector<RelativeSimilarity> cycle = problem.edges;
  for (RelativeSimilarity& edge : cycle) {
    edge.num_inliers = 25;
  }
  EXPECT_EQ(AverageSimilarities(communities, cycle, options).NumParts(), 1);
}

TEST(AverageSimilarities, WeaklySupportedEdgeTakesUpTheDisagreement) {
  // Communities of equal standing; the wrong edge has the fewest inliers.
  // It alone is dropped and no community leaves the merge.
  int bent = -1;
  Problem problem = MakeBentCycle({100, 100, 100, 100, 100}, 23, 0, 1, &bent);
  for (RelativeSimilarity& edge : problem.edges) {
    edge.num_inliers = 300;
  }
  problem.edges[bent].num_inliers = 40;
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  ExpectAlignedWithoutEdge(result, problem, bent);
}

TEST(AverageSimilarities, EdgeFewImagePairsConfirmTakesUpTheDisagreement) {
  // A triangle whose edges all have full support, but the wrong one explains
  // the matches of fewer image pairs between its communities (it rests on a
  // stretch of one that its own mapper misplaced, say): it alone is dropped
  // and the smallest community follows its other edge.
  int bent = -1;
  Problem problem = MakeBentCycle({50, 47, 29}, 24, 1, 2, &bent);
  const int right = FindEdge(problem, 0, 2);
  const int other = FindEdge(problem, 0, 1);
  ASSERT_GE(right, 0);
  ASSERT_GE(other, 0);
  for (RelativeSimilarity& edge : problem.edges) {
    edge.num_inliers = 1500;
  }
  problem.edges[other].num_explained_cross_pairs = 32;
  problem.edges[right].num_explained_cross_pairs = 25;
  problem.edges[bent].num_explained_cross_pairs = 14;
  ExpectAlignedWithoutEdge(
      AverageSimilarities(
          problem.Communities(), problem.edges, SimilarityAveragingOptions()),
      problem,
      bent);

  // Confirmed by more pairs, the same wrong edge outweighs the right one and
  // takes the smallest community with it.
  problem.edges[bent].num_explained_cross_pairs = 29;
  const SimilarityAveragingResult trusting = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_FALSE(trusting.edges[right].kept);
  EXPECT_TRUE(trusting.edges[bent].kept);
}

// Drift around a loop of many communities: every similarity of the cycle
// maps its points `drift` further along the world's x axis than the truth
// (as scale drift inside each community shifts where its far side meets
// the next), so the cycle does not close by num_communities * drift. The
// smallest community's edges are the least confident; each edge is
// confirmed by `num_agreeing` of its 6 shared images.
Problem MakeDriftingLoop(const int num_communities,
                         const double drift,
                         const int num_agreeing) {
  std::vector<int> sizes(num_communities, 300);
  sizes[num_communities / 2] = 25;
  Problem problem = MakeCycle(sizes, 24);
  const Sim3d shift(
      1, Eigen::Quaterniond::Identity(), drift * Eigen::Vector3d::UnitX());
  for (RelativeSimilarity& edge : problem.edges) {
    const Sim3d& world_from_1 = problem.world_from_community[edge.community1];
    const Sim3d& world_from_2 = problem.world_from_community[edge.community2];
    edge.second_from_first = Inverse(world_from_2) * shift * world_from_1;
    for (size_t k = 0; k < edge.points1.size(); ++k) {
      edge.points2[k] = edge.second_from_first * edge.points1[k];
    }
    edge.num_inliers = 300;
    edge.num_shared_images = 6;
    edge.num_agreeing_shared_images = num_agreeing;
  }
  // The small community's links see little of it: their points spread a
  // fifth as far, so in units of their spread they are the first to exceed
  // the bound (as the 29-image walkway piece of a 10,050-image loop did).
  for (RelativeSimilarity& edge : problem.edges) {
    if (edge.community1 != num_communities / 2 &&
        edge.community2 != num_communities / 2) {
      continue;
    }
    Eigen::Vector3d center = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& point : edge.points1) {
      center += point / edge.points1.size();
    }
    for (size_t k = 0; k < edge.points1.size(); ++k) {
      edge.points1[k] = center + 0.2 * (edge.points1[k] - center);
      edge.points2[k] = edge.second_from_first * edge.points1[k];
    }
  }
  return problem;
}

TEST(AverageSimilarities, LoopThatDoesNotCloseOpensAtOneLink) {
  // 30 communities, 0.6 units of drift per edge (the edges' points spread
  // about 15 units): the loop's gap of 18 units is more than a spread. L1
  // puts it on one link, which leaves; the others, a path, keep every
  // community in one part (the global refinement closes the loop).
  const Problem problem = MakeDriftingLoop(30, 0.6, /*num_agreeing=*/6);
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_EQ(result.NumParts(), 1);
  int num_dropped = 0;
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    num_dropped += result.edges[e].kept ? 0 : 1;
  }
  EXPECT_EQ(num_dropped, 1);
}

// `num_points` points on a patch of `spread` around `center` (world frame),
// as the inliers of the edge between `community1` and `community2`: each
// point in the two communities' frames, exactly.
RelativeSimilarity PatchEdge(const Problem& problem,
                             const int community1,
                             const int community2,
                             const Eigen::Vector3d& center,
                             const double spread,
                             const int num_points,
                             std::mt19937* rng) {
  const Sim3d& world_from_1 = problem.world_from_community[community1];
  const Sim3d& world_from_2 = problem.world_from_community[community2];
  RelativeSimilarity edge;
  edge.community1 = community1;
  edge.community2 = community2;
  edge.second_from_first = Inverse(world_from_2) * world_from_1;
  edge.num_inliers = num_points;
  std::normal_distribution<double> normal(0, spread);
  for (int k = 0; k < num_points; ++k) {
    const Eigen::Vector3d world_point =
        center + Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng));
    edge.points1.push_back(Inverse(world_from_1) * world_point);
    edge.points2.push_back(Inverse(world_from_2) * world_point);
  }
  return edge;
}

// Three communities around a loop, closed by a weak link (edge 2): 12
// inliers on a small patch far from community 0's origin, its points right
// but its rotation 6.6 degrees off (a similarity fitted to a few clustered
// points; measured so on a generated loop). Averaged with it in, the
// rotation averaging leans a little toward it, which moves its patch by
// more than the bound; the other two links alone place its points where
// they are.
Problem MakeLoopClosedByWeakLink(std::mt19937* rng) {
  Problem problem;
  problem.sizes = {80, 70, 60};
  problem.world_from_community = {
      Sim3d(),
      Sim3d(0.98,
            Eigen::Quaterniond(Eigen::AngleAxisd(
                0.6, Eigen::Vector3d(0, 1, 0.2).normalized())),
            Eigen::Vector3d(7.5, -0.1, -1.4)),
      Sim3d(0.9,
            Eigen::Quaterniond(Eigen::AngleAxisd(
                2.7, Eigen::Vector3d(0.1, -1, 0.2).normalized())),
            Eigen::Vector3d(2.3, -1.5, -7.0))};
  problem.edges.push_back(
      PatchEdge(problem, 0, 1, Eigen::Vector3d(4, 0, -1), 0.7, 275, rng));
  problem.edges.push_back(
      PatchEdge(problem, 1, 2, Eigen::Vector3d(5, -1, -4), 0.6, 203, rng));
  RelativeSimilarity weak =
      PatchEdge(problem, 0, 2, Eigen::Vector3d(1, -1, -6), 0.25, 12, rng);
  weak.second_from_first.rotation() =
      Eigen::Quaterniond(
          Eigen::AngleAxisd(DegToRad(6.6), Eigen::Vector3d::UnitX())) *
      weak.second_from_first.rotation();
  problem.edges.push_back(weak);
  problem.is_outlier.assign(3, false);
  return problem;
}

TEST(AverageSimilarities, WeakLinkBeyondTheBoundOpensItsCycle) {
  std::mt19937 rng(3);
  const Problem problem = MakeLoopClosedByWeakLink(&rng);
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_EQ(result.NumParts(), 1);
  EXPECT_TRUE(result.edges[0].kept);
  EXPECT_TRUE(result.edges[1].kept);
  EXPECT_FALSE(result.edges[2].kept);
  // The two strong links place the communities right.
  EXPECT_LT(MaxErrors(result, problem).rotation_deg, 1e-6);
}

TEST(AverageSimilarities, BridgeBeyondTheBoundIsNoLinkOfACycle) {
  // The loop above with a fourth community hung on community 1 by a bridge
  // whose own points fit it loosely. The bridge is no link of the cycle:
  // its shared images keep it, and the cycle's weak link is the one that
  // goes.
  std::mt19937 rng(3);
  Problem problem = MakeLoopClosedByWeakLink(&rng);
  problem.sizes.push_back(50);
  problem.world_from_community.emplace_back(
      1.1,
      Eigen::Quaterniond(Eigen::AngleAxisd(-0.8, Eigen::Vector3d::UnitY())),
      Eigen::Vector3d(14, 0.5, -2));
  RelativeSimilarity bridge =
      PatchEdge(problem, 1, 3, Eigen::Vector3d(11, 0, -2), 1.0, 60, &rng);
  std::normal_distribution<double> noise(0, 0.5);
  for (Eigen::Vector3d& point : bridge.points2) {
    point += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  bridge.num_shared_images = 3;
  bridge.num_agreeing_shared_images = 3;
  problem.edges.push_back(bridge);
  problem.is_outlier.push_back(false);

  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  const double bound = SimilarityAveragingOptions().max_relative_displacement;
  EXPECT_EQ(result.NumParts(), 1);
  EXPECT_GT(result.edges[3].relative_displacement, bound);
  EXPECT_TRUE(result.edges[3].kept);
  EXPECT_FALSE(result.edges[2].kept);
  EXPECT_TRUE(result.edges[0].kept);
  EXPECT_TRUE(result.edges[1].kept);
}

TEST(AverageSimilarities, BridgeIsNotJudgedByItsOwnFit) {
  // Two communities joined by one link whose own points fit it loosely
  // (half a spread): no other link disagrees with it, and its shared images
  // confirm it, so it joins them.
  std::mt19937 rng(4);
  Problem problem;
  problem.sizes = {50, 40};
  problem.world_from_community = {Sim3d(),
                                  Sim3d(1.2,
                                        Eigen::Quaterniond(Eigen::AngleAxisd(
                                            0.4, Eigen::Vector3d::UnitZ())),
                                        Eigen::Vector3d(5, 1, 0))};
  RelativeSimilarity edge =
      PatchEdge(problem, 0, 1, Eigen::Vector3d(2, 0, 1), 1.0, 60, &rng);
  std::normal_distribution<double> noise(0, 0.5);
  for (Eigen::Vector3d& point : edge.points2) {
    point += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  edge.num_shared_images = 3;
  edge.num_agreeing_shared_images = 3;
  problem.edges = {edge};
  const SimilarityAveragingResult result = AverageSimilarities(
      problem.Communities(), problem.edges, SimilarityAveragingOptions());
  EXPECT_GT(result.edges[0].relative_displacement,
            SimilarityAveragingOptions().max_relative_displacement);
  EXPECT_TRUE(result.edges[0].kept);
  EXPECT_EQ(result.NumParts(), 1);
}

}  // namespace
}  // namespace colmap
