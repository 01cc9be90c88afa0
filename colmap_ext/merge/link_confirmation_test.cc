#include "colmap_ext/merge/link_confirmation.h"

#include "colmap/math/math.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// The averaging's displacement bound (SimilarityAveragingOptions).
const double kBound = SimilarityAveragingOptions().max_relative_displacement;

// The averaging's result for the similarities `*similarities`: communities
// 0 and 1 of one part, joined through `num_links` kept links in a row (via
// communities 3, 4, ...), and through a second such path if `parallel`;
// community 1 placed relative to 0 as `merged_second_from_first`, community
// 2 in a part of its own.
SimilarityAveragingResult TwoJoinedOneApart(
    const Sim3d& merged_second_from_first,
    std::vector<RelativeSimilarity>* similarities,
    const int num_links = 2,
    const bool parallel = false) {
  SimilarityAveragingResult averaging;
  averaging.part_of_community = {0, 0, 1};
  averaging.world_from_community = {
      Sim3d(), Inverse(merged_second_from_first), Sim3d()};
  similarities->clear();
  for (int path = 0; path < (parallel ? 2 : 1); ++path) {
    int previous = 0;
    for (int link = 0; link < num_links; ++link) {
      int next = 1;
      if (link + 1 < num_links) {
        next = static_cast<int>(averaging.part_of_community.size());
        averaging.part_of_community.push_back(0);
        averaging.world_from_community.push_back(Sim3d());
      }
      RelativeSimilarity similarity;
      similarity.community1 = previous;
      similarity.community2 = next;
      similarities->push_back(similarity);
      SimilarityAveragingResult::EdgeReport report;
      report.kept = true;
      averaging.edges.push_back(report);
      previous = next;
    }
  }
  return averaging;
}

// A rejected transform with inliers X2 = second_from_first(X1) on a patch of
// points (spread about 1) around `center`.
RejectedSimilarity Rejected(const int community1,
                            const int community2,
                            const Sim3d& second_from_first,
                            const Eigen::Vector3d& center) {
  RejectedSimilarity rejected;
  RelativeSimilarity& similarity = rejected.similarity;
  similarity.community1 = community1;
  similarity.community2 = community2;
  similarity.second_from_first = second_from_first;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1, 1);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d x1 =
        center + Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    similarity.points1.push_back(x1);
    similarity.points2.push_back(second_from_first * x1);
  }
  return rejected;
}

TEST(ResidualsAgainstMerge, RightTransformWithDriftIsConfirmed) {
  // The averaging placed community 1 through other links, with a loop's
  // drift: 1 degree and 1% of scale off the transform the check rejected.
  const Sim3d right(
      1.2,
      Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(1, 2, 3));
  const Sim3d drifted(1.2 * 1.01,
                      Eigen::Quaterniond(Eigen::AngleAxisd(
                          0.5 + DegToRad(1.0), Eigen::Vector3d::UnitZ())),
                      Eigen::Vector3d(1, 2, 3));
  std::vector<RelativeSimilarity> similarities;
  const SimilarityAveragingResult averaging =
      TwoJoinedOneApart(drifted, &similarities);
  const MergeResiduals residuals = ResidualsAgainstMerge(
      Rejected(0, 1, right, Eigen::Vector3d(2, 0, 0)), similarities, averaging);
  EXPECT_TRUE(residuals.joined);
  EXPECT_NEAR(residuals.report.rotation_residual_deg, 1.0, 1e-6);
  EXPECT_NEAR(residuals.report.log_scale_residual, std::log(1.01), 1e-9);
  EXPECT_LT(residuals.report.relative_displacement, 0.1);
  EXPECT_TRUE(residuals.WithinBound(kBound));
}

TEST(ResidualsAgainstMerge, IdenticalStructureElsewhereIsNot) {
  // Two identical facades 10 spreads apart, matched onto each other: the
  // rejected transform has the right rotation and scale but stacks them.
  const Sim3d right(
      1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  const Sim3d stacked(
      1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(10, 0, 0));
  std::vector<RelativeSimilarity> similarities;
  const SimilarityAveragingResult averaging =
      TwoJoinedOneApart(right, &similarities, /*num_links=*/10);
  const MergeResiduals residuals =
      ResidualsAgainstMerge(Rejected(0, 1, stacked, Eigen::Vector3d::Zero()),
                            similarities,
                            averaging);
  EXPECT_TRUE(residuals.joined);
  EXPECT_NEAR(residuals.report.rotation_residual_deg, 0.0, 1e-6);
  EXPECT_GT(residuals.report.relative_displacement, 5);
  EXPECT_FALSE(residuals.WithinBound(kBound));
  // Not even across a path of 10 links with the bound grown for its drift.
  EXPECT_NEAR(residuals.path_resistance, 10.0, 1e-9);
  EXPECT_FALSE(residuals.WithinBound(kBound, /*max_drift_factor=*/
                                     std::sqrt(10.0)));
}

TEST(ResidualsAgainstMerge, FlippedFacadeIsNot) {
  const Sim3d flipped(
      1.0,
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY())),
      Eigen::Vector3d::Zero());
  std::vector<RelativeSimilarity> similarities;
  const SimilarityAveragingResult averaging =
      TwoJoinedOneApart(Sim3d(), &similarities);
  const MergeResiduals residuals =
      ResidualsAgainstMerge(Rejected(0, 1, flipped, Eigen::Vector3d::Zero()),
                            similarities,
                            averaging);
  EXPECT_NEAR(residuals.report.rotation_residual_deg, 180.0, 1e-6);
  EXPECT_GT(residuals.report.relative_displacement, 1);
  EXPECT_FALSE(residuals.WithinBound(kBound));
}

TEST(ResidualsAgainstMerge, NothingConfirmsALinkBetweenParts) {
  // Communities 0 and 2 are joined by nothing else (two models): the
  // rejected transform stays rejected, right or wrong.
  std::vector<RelativeSimilarity> similarities;
  SimilarityAveragingResult averaging =
      TwoJoinedOneApart(Sim3d(), &similarities);
  const MergeResiduals residuals =
      ResidualsAgainstMerge(Rejected(0, 2, Sim3d(), Eigen::Vector3d::Zero()),
                            similarities,
                            averaging);
  EXPECT_FALSE(residuals.joined);
  EXPECT_FALSE(residuals.WithinBound(kBound, /*max_drift_factor=*/10));
}

TEST(ResidualsAgainstMerge, BoundGrowsWithThePathsDrift) {
  // The merge placed community 1 about a third of a spread off the rejected
  // transform: beyond the averaging's bound (0.2), within it grown for the
  // drift of 3 links in a row (times sqrt(3)), not over two parallel paths
  // of 2 links (resistance 1).
  const Sim3d right(
      1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  const RejectedSimilarity rejected =
      Rejected(0, 1, right, Eigen::Vector3d::Zero());
  std::vector<RelativeSimilarity> similarities;
  const Sim3d drifted(
      1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.3, 0, 0));
  SimilarityAveragingResult averaging =
      TwoJoinedOneApart(drifted, &similarities, /*num_links=*/3);
  const MergeResiduals residuals =
      ResidualsAgainstMerge(rejected, similarities, averaging);
  ASSERT_GT(residuals.report.relative_displacement, kBound);
  ASSERT_LT(residuals.report.relative_displacement, kBound * std::sqrt(3.0));
  EXPECT_NEAR(residuals.path_resistance, 3.0, 1e-9);
  EXPECT_NEAR(residuals.DriftFactor(2.0), std::sqrt(3.0), 1e-9);
  EXPECT_FALSE(residuals.WithinBound(kBound));
  EXPECT_TRUE(residuals.WithinBound(kBound, /*max_drift_factor=*/2.0));
  // The factor is capped.
  EXPECT_NEAR(residuals.DriftFactor(1.5), 1.5, 1e-9);

  // Scale counts as the points it moves: 50% off across the same 3 links
  // puts them half a spread apart, beyond the grown bound.
  const Sim3d scaled(
      1.5, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  averaging = TwoJoinedOneApart(scaled, &similarities, /*num_links=*/3);
  const MergeResiduals scale_drift =
      ResidualsAgainstMerge(rejected, similarities, averaging);
  EXPECT_NEAR(scale_drift.report.log_scale_residual, std::log(1.5), 1e-9);
  EXPECT_NEAR(scale_drift.report.relative_displacement, 0.5, 0.05);
  EXPECT_FALSE(scale_drift.WithinBound(kBound, /*max_drift_factor=*/2.0));

  averaging = TwoJoinedOneApart(
      drifted, &similarities, /*num_links=*/2, /*parallel=*/true);
  const MergeResiduals parallel =
      ResidualsAgainstMerge(rejected, similarities, averaging);
  EXPECT_NEAR(parallel.path_resistance, 1.0, 1e-9);
  EXPECT_FALSE(parallel.WithinBound(kBound, /*max_drift_factor=*/2.0));

  // Put in one part with no kept link between them, the bound stays.
  for (auto& report : averaging.edges) {
    report.kept = false;
  }
  EXPECT_EQ(
      ResidualsAgainstMerge(rejected, similarities, averaging).path_resistance,
      1.0);
}

TEST(ConfirmRejectedLinks, KeepsThePairsOfConfirmedTransformsOnly) {
  // Communities 0 and 1 joined through other links as the truth joins
  // them. Of two transforms the co-visibility check rejected between them,
  // the right one is confirmed and its pairs stay; the one stacking two
  // identical facades 10 spreads apart is not, and neither is any pair
  // that supported no transform at all.
  std::vector<RelativeSimilarity> similarities;
  const SimilarityAveragingResult averaging =
      TwoJoinedOneApart(Sim3d(), &similarities);
  CommunitySimilarities community_similarities;
  community_similarities.similarities = similarities;
  RejectedSimilarity right =
      Rejected(0, 1, Sim3d(), Eigen::Vector3d::Zero());
  right.pairs = {1};
  RejectedSimilarity stacked = Rejected(
      0,
      1,
      Sim3d(1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(10, 0, 0)),
      Eigen::Vector3d::Zero());
  stacked.pairs = {2};
  community_similarities.rejected_similarities = {right, stacked};
  community_similarities.false_pairs = {1, 2, 3};
  EXPECT_EQ(ConfirmRejectedLinks(community_similarities,
                                 averaging,
                                 kBound,
                                 /*max_drift_factor=*/1.5),
            std::unordered_set<image_pair_t>({2, 3}));
}

}  // namespace
}  // namespace colmap
