#include "colmap_ext/merge/link_confirmation.h"

#include "colmap_ext/util/union_find.h"

#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

namespace colmap {

namespace {

// The effective resistance between communities c1 and c2 in the graph of
// the kept edges, each a unit resistance: with c2 grounded, the potential
// at c1 when a unit current enters there (L x = e_c1 over the communities
// the kept edges connect to c1). 1 if they do not connect them (the bound
// then stays as it is).
double EffectiveResistance(const std::vector<RelativeSimilarity>& similarities,
                           const SimilarityAveragingResult& averaging,
                           const int c1,
                           const int c2) {
  std::vector<std::pair<int, int>> kept_edges;
  for (size_t e = 0; e < similarities.size(); ++e) {
    if (averaging.edges[e].kept) {
      kept_edges.emplace_back(similarities[e].community1,
                              similarities[e].community2);
    }
  }
  const std::vector<int> labels = ConnectedComponentLabels(
      static_cast<int>(averaging.part_of_community.size()), kept_edges);
  if (labels[c1] != labels[c2]) {
    return 1.0;
  }
  std::map<int, int> index;  // Community -> row, c2 grounded (no row).
  for (size_t c = 0; c < labels.size(); ++c) {
    if (labels[c] == labels[c1] && static_cast<int>(c) != c2) {
      index.emplace(static_cast<int>(c), static_cast<int>(index.size()));
    }
  }
  std::vector<Eigen::Triplet<double>> triplets;
  for (const std::pair<int, int>& edge : kept_edges) {
    if (labels[edge.first] != labels[c1]) {
      continue;
    }
    const auto it1 = index.find(edge.first);
    const auto it2 = index.find(edge.second);
    if (it1 != index.end()) {
      triplets.emplace_back(it1->second, it1->second, 1.0);
    }
    if (it2 != index.end()) {
      triplets.emplace_back(it2->second, it2->second, 1.0);
    }
    if (it1 != index.end() && it2 != index.end()) {
      triplets.emplace_back(it1->second, it2->second, -1.0);
      triplets.emplace_back(it2->second, it1->second, -1.0);
    }
  }
  const int n = static_cast<int>(index.size());
  Eigen::SparseMatrix<double> laplacian(n, n);
  laplacian.setFromTriplets(triplets.begin(), triplets.end());
  // Connected and grounded: positive definite.
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(laplacian);
  Eigen::VectorXd current = Eigen::VectorXd::Zero(n);
  current(index.at(c1)) = 1.0;
  const Eigen::VectorXd potential = solver.solve(current);
  const double resistance = potential(index.at(c1));
  return solver.info() == Eigen::Success && std::isfinite(resistance)
             ? resistance
             : 1.0;
}

}  // namespace

double MergeResiduals::DriftFactor(const double max_drift_factor) const {
  return std::min(std::max(1.0, std::sqrt(path_resistance)),
                  std::max(1.0, max_drift_factor));
}

bool MergeResiduals::WithinBound(const double max_relative_displacement,
                                 const double max_drift_factor) const {
  return joined &&
         EdgeWithinBound(
             report, max_relative_displacement * DriftFactor(max_drift_factor));
}

MergeResiduals ResidualsAgainstMerge(
    const RejectedSimilarity& rejected,
    const std::vector<RelativeSimilarity>& similarities,
    const SimilarityAveragingResult& averaging) {
  const int c1 = rejected.similarity.community1;
  const int c2 = rejected.similarity.community2;
  THROW_CHECK_GE(std::min(c1, c2), 0);
  THROW_CHECK_LT(std::max(c1, c2), averaging.part_of_community.size());
  THROW_CHECK_EQ(similarities.size(), averaging.edges.size());
  MergeResiduals residuals;
  if (c1 == c2 ||
      averaging.part_of_community[c1] != averaging.part_of_community[c2]) {
    return residuals;
  }
  residuals.joined = true;
  residuals.report =
      ComputeEdgeResiduals(rejected.similarity, averaging.world_from_community);
  residuals.path_resistance =
      EffectiveResistance(similarities, averaging, c1, c2);
  return residuals;
}

std::unordered_set<image_pair_t> ConfirmRejectedLinks(
    const CommunitySimilarities& community_similarities,
    const SimilarityAveragingResult& averaging,
    const double max_relative_displacement,
    const double max_drift_factor) {
  std::unordered_set<image_pair_t> false_pairs =
      community_similarities.false_pairs;
  for (const RejectedSimilarity& rejected :
       community_similarities.rejected_similarities) {
    const MergeResiduals residuals = ResidualsAgainstMerge(
        rejected, community_similarities.similarities, averaging);
    if (!residuals.joined) {
      continue;  // Not joined through other links: nothing to confirm it.
    }
    const bool confirmed =
        residuals.WithinBound(max_relative_displacement, max_drift_factor);
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: the similarity the co-visibility check rejected "
        "(%d inliers) against the merge: displacement %.4f (rotation %.3f deg, "
        "scale %.4f; links between them: resistance %.2f, bound times %.2f) "
        "-> %s",
        rejected.similarity.community1,
        rejected.similarity.community2,
        static_cast<int>(rejected.similarity.points1.size()),
        residuals.report.relative_displacement,
        residuals.report.rotation_residual_deg,
        residuals.report.log_scale_residual,
        residuals.path_resistance,
        residuals.DriftFactor(max_drift_factor),
        confirmed ? StringPrintf("confirmed: its %d image pairs stay in the "
                                 "refinement",
                                 static_cast<int>(rejected.pairs.size()))
                        .c_str()
                  : "still rejected");
    if (confirmed) {
      for (const image_pair_t pair_id : rejected.pairs) {
        false_pairs.erase(pair_id);
      }
    }
  }
  return false_pairs;
}

}  // namespace colmap
