#include "colmap_ext/merge/similarity_averaging.h"

#include "colmap_ext/merge/rotation_averaging.h"
#include "colmap_ext/util/option_check.h"
#include "colmap_ext/util/union_find.h"

#include "colmap/math/math.h"
#include "colmap/optim/least_absolute_deviations.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/SparseCore>

namespace colmap {

bool SimilarityAveragingOptions::Check() const {
  return CheckFlag(max_relative_displacement > 0,
                   "averaging_max_relative_displacement",
                   max_relative_displacement,
                   "positive");
}

int SimilarityAveragingResult::NumParts() const {
  return part_of_community.empty()
             ? 0
             : 1 + *std::max_element(part_of_community.begin(),
                                     part_of_community.end());
}

namespace {

// Solves x_i - x_j = b_e (dim rows per edge e = (i, j), weighted by
// edge_weights[e]) in L1 over nodes 0..num_nodes-1 of one part,
// x_reference = 0. `x` has dim entries per node.
bool SolveDifferenceSystem(const int num_nodes,
                           const std::vector<std::pair<int, int>>& edges,
                           const std::vector<double>& edge_weights,
                           const int dim,
                           const int reference,
                           const Eigen::VectorXd& b,
                           Eigen::VectorXd* x) {
  // A node's variable block; the reference has none.
  const auto column = [reference](const int node) {
    return node < reference ? node : node - 1;
  };
  x->setZero(dim * num_nodes);
  if (num_nodes == 1) {
    return true;
  }

  std::vector<Eigen::Triplet<double>> triplets;
  for (size_t e = 0; e < edges.size(); ++e) {
    for (int d = 0; d < dim; ++d) {
      if (edges[e].first != reference) {
        triplets.emplace_back(
            dim * e + d, dim * column(edges[e].first) + d, edge_weights[e]);
      }
      if (edges[e].second != reference) {
        triplets.emplace_back(
            dim * e + d, dim * column(edges[e].second) + d, -edge_weights[e]);
      }
    }
  }
  Eigen::SparseMatrix<double> A(dim * edges.size(), dim * (num_nodes - 1));
  A.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::VectorXd weighted_b = b;
  for (size_t e = 0; e < edges.size(); ++e) {
    weighted_b.segment(dim * e, dim) *= edge_weights[e];
  }

  LeastAbsoluteDeviationSolver::Options l1_options;
  l1_options.max_num_iterations = 20000;
  l1_options.absolute_tolerance = 1e-12;
  l1_options.relative_tolerance = 1e-10;
  const LeastAbsoluteDeviationSolver solver(l1_options, A);
  Eigen::VectorXd solution = Eigen::VectorXd::Zero(A.cols());
  if (!solver.Solve(weighted_b, &solution)) {
    return false;
  }

  for (int node = 0; node < num_nodes; ++node) {
    if (node != reference) {
      x->segment(dim * node, dim) = solution.segment(dim * column(node), dim);
    }
  }
  return true;
}

// The translation measurement T_i - T_j of an edge, given scales and
// rotations: the median difference of its correspondences.
Eigen::Vector3d TranslationMeasurement(const RelativeSimilarity& edge,
                                       const Sim3d& world_from_first,
                                       const Sim3d& world_from_second) {
  std::vector<Eigen::Vector3d> differences;
  for (size_t k = 0; k < edge.points1.size(); ++k) {
    differences.push_back(
        world_from_second.scale() *
            (world_from_second.rotation() * edge.points2[k]) -
        world_from_first.scale() *
            (world_from_first.rotation() * edge.points1[k]));
  }
  return CoordinateWiseMedian(differences);
}

// Averages the similarities of one connected part in place.
bool AveragePart(const std::vector<int>& nodes,
                 const std::vector<const RelativeSimilarity*>& edges,
                 const std::vector<double>& edge_weights,
                 const int reference,
                 std::vector<Sim3d>* world_from_community) {
  // The part's nodes and edges by their index in `nodes`.
  const int num_nodes = static_cast<int>(nodes.size());
  std::map<int, int> local;
  for (int k = 0; k < num_nodes; ++k) {
    local.emplace(nodes[k], k);
  }
  const int local_reference = local.at(reference);
  std::vector<std::pair<int, int>> edge_nodes;
  for (const RelativeSimilarity* edge : edges) {
    edge_nodes.emplace_back(local.at(edge->community1),
                            local.at(edge->community2));
  }
  const auto solve_differences =
      [&](const int dim, const Eigen::VectorXd& b, Eigen::VectorXd* x) {
        return SolveDifferenceSystem(
            num_nodes, edge_nodes, edge_weights, dim, local_reference, b, x);
      };

  // 1. Scale: log s_i - log s_j = log s_ij.
  Eigen::VectorXd log_scales;
  {
    Eigen::VectorXd b(edges.size());
    for (size_t e = 0; e < edges.size(); ++e) {
      b(e) = std::log(edges[e]->second_from_first.scale());
    }
    if (!solve_differences(/*dim=*/1, b, &log_scales)) {
      return false;
    }
  }

  // 2. Rotation: R_i = R_j R_ij, i.e. R_j^T = R_ij R_i^T, averaged on the
  // transposes (community_from_world rotations).
  std::vector<Eigen::Quaterniond> community_from_world;
  {
    std::vector<RelativeRotation> relative_rotations;
    for (size_t e = 0; e < edges.size(); ++e) {
      relative_rotations.push_back({edge_nodes[e].first,
                                    edge_nodes[e].second,
                                    edges[e]->second_from_first.rotation(),
                                    edge_weights[e]});
    }
    if (!AverageRotations(num_nodes,
                          relative_rotations,
                          local_reference,
                          &community_from_world)) {
      return false;
    }
  }
  for (size_t k = 0; k < nodes.size(); ++k) {
    Sim3d& transform = (*world_from_community)[nodes[k]];
    transform.scale() = std::exp(log_scales(k));
    transform.rotation() = community_from_world[k].inverse();
    transform.translation().setZero();
  }

  // 3. Translation: T_i - T_j = T_ij, re-estimated from the correspondences.
  Eigen::VectorXd b(3 * edges.size());
  for (size_t e = 0; e < edges.size(); ++e) {
    b.segment<3>(3 * e) =
        TranslationMeasurement(*edges[e],
                               (*world_from_community)[edges[e]->community1],
                               (*world_from_community)[edges[e]->community2]);
  }
  Eigen::VectorXd translations;
  if (!solve_differences(/*dim=*/3, b, &translations)) {
    return false;
  }
  for (size_t k = 0; k < nodes.size(); ++k) {
    (*world_from_community)[nodes[k]].translation() =
        translations.segment<3>(3 * k);
  }
  return true;
}

// The residual of `edge` under the placement `world_from_community`, as the
// averaging judges its edges (EdgeReport::relative_displacement).
double RelativeDisplacement(const RelativeSimilarity& edge,
                            const std::vector<Sim3d>& world_from_community) {
  const Sim3d& world_from_first = world_from_community[edge.community1];
  const Sim3d& world_from_second = world_from_community[edge.community2];
  std::vector<Eigen::Vector3d> world_points2(edge.points2.size());
  std::vector<double> displacements(edge.points1.size());
  for (size_t k = 0; k < edge.points1.size(); ++k) {
    world_points2[k] = world_from_second * edge.points2[k];
    displacements[k] =
        (world_from_first * edge.points1[k] - world_points2[k]).norm();
  }
  const double spread = MedianDistanceToMedian(world_points2);
  const double displacement = Median(displacements);
  // A non-finite placement gives an infinite (or NaN) displacement.
  return spread > 0
             ? displacement / spread
             : (displacement == 0 ? 0.0
                                  : std::numeric_limits<double>::infinity());
}

// Whether the images both communities of `edge` registered contradict its
// similarity (EdgeReport::contradicted). One image placed elsewhere can be
// misregistered; more, and a majority, mean that the similarity or one of
// its models is wrong where the two overlap.
bool SharedImagesContradict(const RelativeSimilarity& edge) {
  const int num_elsewhere =
      edge.num_shared_images - edge.num_agreeing_shared_images;
  return num_elsewhere >= 2 && num_elsewhere >= edge.num_agreeing_shared_images;
}

// The weights of the edges in the averaging, in [1 - kWeightRange, 1]: their
// order decides where a cycle's disagreement goes, while around every
// community a majority of right edges still outweighs a minority of wrong
// ones, as L1 needs.
std::vector<double> EdgeWeights(
    const std::vector<RelativeSimilarity>& relative_similarities) {
  constexpr double kWeightRange = 0.4;
  std::vector<double> edge_weights(relative_similarities.size());
  double max_weight = 0;
  for (size_t e = 0; e < relative_similarities.size(); ++e) {
    // The image pairs that confirm the similarity, fewer below full support.
    const RelativeSimilarity& edge = relative_similarities[e];
    edge_weights[e] = std::max(1,
                               edge.num_explained_cross_pairs +
                                   edge.num_agreeing_shared_images) *
                      std::min(1.0, edge.num_inliers / kFullSupportNumInliers);
    max_weight = std::max(max_weight, edge_weights[e]);
  }
  for (double& weight : edge_weights) {
    weight = 1 - kWeightRange +
             kWeightRange * (max_weight > 0 ? weight / max_weight : 1);
  }
  return edge_weights;
}

// The state the rounds of the averaging share.
struct AveragingRounds {
  const std::vector<AveragedCommunity>& communities;
  const std::vector<RelativeSimilarity>& relative_similarities;
  const SimilarityAveragingOptions& options;
  std::vector<double> edge_weights;
  SimilarityAveragingResult result;

  // Per round: the parts over the kept edges, each community's component.
  std::vector<std::vector<int>> parts;
  std::vector<int> component;

  int NumCommunities() const { return static_cast<int>(communities.size()); }

  // The kept edges' communities, but for edge `skip`.
  std::vector<std::pair<int, int>> KeptEdges(
      const size_t skip = std::numeric_limits<size_t>::max()) const {
    std::vector<std::pair<int, int>> kept_edges;
    for (size_t e = 0; e < relative_similarities.size(); ++e) {
      if (e != skip && result.edges[e].kept) {
        kept_edges.emplace_back(relative_similarities[e].community1,
                                relative_similarities[e].community2);
      }
    }
    return kept_edges;
  }

  // Whether no other kept edge joins the communities of edge e, directly or
  // through others: e lies on no cycle of kept edges.
  bool IsBridge(const size_t e) const {
    const std::vector<int> labels =
        ConnectedComponentLabels(NumCommunities(), KeptEdges(e));
    return labels[relative_similarities[e].community1] !=
           labels[relative_similarities[e].community2];
  }

  // The parts over the kept edges, in the order of their smallest community.
  void FindParts() {
    component = ConnectedComponentLabels(NumCommunities(), KeptEdges());
    parts.clear();
    std::map<int, size_t> part_of_label;
    for (int node = 0; node < NumCommunities(); ++node) {
      const auto it =
          part_of_label.emplace(component[node], parts.size()).first;
      if (it->second == parts.size()) {
        parts.emplace_back();
      }
      parts[it->second].push_back(node);
    }
  }

  // Averages every part from its largest community. A part whose averaging
  // fails loses its edges (the next round splits it): returns false then.
  bool AverageParts() {
    bool failed = false;
    for (const std::vector<int>& nodes : parts) {
      // The first of the largest communities.
      const int reference = *std::max_element(
          nodes.begin(), nodes.end(), [&](const int a, const int b) {
            return communities[a].num_images < communities[b].num_images;
          });
      std::vector<const RelativeSimilarity*> edges;
      std::vector<double> weights;
      std::vector<size_t> edge_indices;
      for (size_t e = 0; e < relative_similarities.size(); ++e) {
        if (result.edges[e].kept &&
            component[relative_similarities[e].community1] ==
                component[reference]) {
          edges.push_back(&relative_similarities[e]);
          weights.push_back(edge_weights[e]);
          edge_indices.push_back(e);
        }
      }
      if (AveragePart(
              nodes, edges, weights, reference, &result.world_from_community)) {
        continue;
      }
      LOG(WARNING) << "Similarity averaging failed for a part of "
                   << nodes.size() << " communities; they are kept apart.";
      for (const size_t e : edge_indices) {
        result.edges[e].kept = false;
      }
      for (const int node : nodes) {
        result.world_from_community[node] = Sim3d();
      }
      failed = failed || !edge_indices.empty();
    }
    return !failed;
  }

  // Rejects each part's kept edge on a cycle furthest beyond the bound, and
  // every edge whose displacement is not finite. Whether any edge went.
  bool RejectWorstEdges() {
    std::map<int, std::pair<double, size_t>> worst_of_part;  // By label.
    bool rejected = false;
    for (size_t e = 0; e < relative_similarities.size(); ++e) {
      if (!result.edges[e].kept) {
        continue;
      }
      const RelativeSimilarity& edge = relative_similarities[e];
      const double displacement =
          RelativeDisplacement(edge, result.world_from_community);
      result.edges[e].relative_displacement = displacement;
      // Written so that a non-finite displacement counts as too large.
      if (displacement <= options.max_relative_displacement) {
        continue;
      }
      if (!std::isfinite(displacement)) {
        result.edges[e].kept = false;
        rejected = true;
        continue;
      }
      // A bridge is placed by its own similarity alone: its displacement is
      // its own fit's residual, not a cycle's disagreement, and its shared
      // images judge it (DropUnconfirmedBridges).
      if (IsBridge(e)) {
        continue;
      }
      auto& worst =
          worst_of_part
              .emplace(component[edge.community1], std::make_pair(0.0, e))
              .first->second;
      if (displacement > worst.first) {
        worst = {displacement, e};
      }
    }
    for (const auto& [label, worst] : worst_of_part) {
      result.edges[worst.second].kept = false;
      rejected = true;
    }
    return rejected;
  }

  // Bridges (edges no cycle of kept edges checks) are fitted as they are,
  // right or wrong: the shared images must confirm them. A wrong bridge
  // (two communities joined by wrong matches alone) misplaces the whole
  // weaker community. Returns whether a bridge was dropped.
  bool DropUnconfirmedBridges() {
    bool dropped_bridge = false;
    for (size_t e = 0; e < relative_similarities.size(); ++e) {
      const RelativeSimilarity& edge = relative_similarities[e];
      // Full support stands in for the shared images where there are few;
      // contradicting ones were left out before the averaging.
      if (result.edges[e].kept && edge.num_inliers < kFullSupportNumInliers &&
          edge.num_agreeing_shared_images < 2 && IsBridge(e)) {
        result.edges[e].kept = false;
        result.edges[e].unconfirmed = true;
        dropped_bridge = true;
      }
    }
    return dropped_bridge;
  }

  // Numbers the parts by size, largest first (ties: smallest community).
  void NumberParts() {
    const auto PartSize = [&](const std::vector<int>& nodes) {
      int size = 0;
      for (const int node : nodes) {
        size += communities[node].num_images;
      }
      return size;
    };
    std::stable_sort(parts.begin(),
                     parts.end(),
                     [&](const std::vector<int>& a, const std::vector<int>& b) {
                       return PartSize(a) > PartSize(b);
                     });
    result.part_of_community.assign(NumCommunities(), -1);
    for (size_t p = 0; p < parts.size(); ++p) {
      for (const int node : parts[p]) {
        result.part_of_community[node] = static_cast<int>(p);
      }
    }
  }
};

}  // namespace

SimilarityAveragingResult AverageSimilarities(
    const std::vector<AveragedCommunity>& communities,
    const std::vector<RelativeSimilarity>& relative_similarities,
    const SimilarityAveragingOptions& options) {
  THROW_CHECK(options.Check());
  const int num_communities = static_cast<int>(communities.size());
  for (const RelativeSimilarity& edge : relative_similarities) {
    THROW_CHECK_GE(edge.community1, 0);
    THROW_CHECK_LT(edge.community1, num_communities);
    THROW_CHECK_GE(edge.community2, 0);
    THROW_CHECK_LT(edge.community2, num_communities);
    THROW_CHECK_NE(edge.community1, edge.community2);
    THROW_CHECK_GT(edge.second_from_first.scale(), 0);
    THROW_CHECK(!edge.points1.empty());
    THROW_CHECK_EQ(edge.points1.size(), edge.points2.size());
  }

  AveragingRounds rounds{communities, relative_similarities, options};
  rounds.edge_weights = EdgeWeights(relative_similarities);
  SimilarityAveragingResult& result = rounds.result;
  result.world_from_community.assign(num_communities, Sim3d());
  result.edges.resize(relative_similarities.size());
  // The shared images measure an edge's similarity directly: an edge they
  // contradict is left out before it can pull the averaging its way.
  for (size_t e = 0; e < relative_similarities.size(); ++e) {
    result.edges[e].contradicted =
        SharedImagesContradict(relative_similarities[e]);
    result.edges[e].kept = !result.edges[e].contradicted;
  }

  // Every round rejects at least one edge, or ends the averaging.
  for (;;) {
    rounds.FindParts();
    const bool averaged = rounds.AverageParts();
    if (rounds.RejectWorstEdges() || !averaged) {
      continue;
    }
    if (!rounds.DropUnconfirmedBridges()) {
      break;
    }
  }
  rounds.NumberParts();
  return std::move(rounds.result);
}

}  // namespace colmap
