#include "colmap_ext/merge/community_alignment.h"

#include "colmap/math/random.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/threading.h"
#include "colmap/util/types.h"

#include <algorithm>
#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace colmap {

CrossEdges GroupCrossEdges(
    const ViewGraph& view_graph,
    const std::unordered_map<image_t, int>& community_of_image) {
  CrossEdges cross_edges;
  for (const ViewGraph::Edge& edge : view_graph.Edges()) {
    const image_t image_id1 = view_graph.ImageIds()[edge.vertex1];
    const image_t image_id2 = view_graph.ImageIds()[edge.vertex2];
    const auto it1 = community_of_image.find(image_id1);
    const auto it2 = community_of_image.find(image_id2);
    if (it1 == community_of_image.end() || it2 == community_of_image.end() ||
        it1->second == it2->second) {
      continue;
    }
    const bool swapped = it1->second > it2->second;
    cross_edges[std::minmax(it1->second, it2->second)].emplace_back(
        swapped ? image_id2 : image_id1, swapped ? image_id1 : image_id2);
  }
  return cross_edges;
}

namespace {

// What one pair of communities gives: its similarity (if usable), its false
// cross pairs and its log line.
struct PairOutcome {
  std::optional<RelativeSimilarity> similarity;
  std::vector<image_pair_t> false_pairs;
  // The inlier point pairs of every transform the co-visibility check rejected.
  std::set<std::pair<point3D_t, point3D_t>> rejected_inliers;
  std::string log;
};

// Images on the border that both models registered: each of their
// keypoints with a 3D point in both is a correspondence.
std::vector<CrossPairMatches> SharedImageMatches(const Reconstruction& model1,
                                                 const Reconstruction& model2) {
  std::vector<CrossPairMatches> cross_pairs;
  for (const image_t image_id : model1.RegImageIds()) {
    if (HasPosedImage(model2, image_id)) {
      cross_pairs.push_back({image_id, image_id, {}});
      for (point2D_t idx = 0; idx < model1.Image(image_id).NumPoints2D();
           ++idx) {
        cross_pairs.back().matches.emplace_back(idx, idx);
      }
    }
  }
  return cross_pairs;
}

// The cross pairs whose linked points mostly supported rejected transforms
// are false: left in the refinement, the matches between two identical
// towers become tracks that tie each point of one tower to its twin on the
// other and bend the merged model.
void RecordFalseCrossPairs(const Reconstruction& model1,
                           const Reconstruction& model2,
                           const std::vector<CrossPairMatches>& cross_pairs,
                           const size_t num_shared_images,
                           PairOutcome* outcome) {
  if (outcome->rejected_inliers.empty()) {
    return;
  }
  for (size_t k = num_shared_images; k < cross_pairs.size(); ++k) {
    const PointCorrespondences pair_points =
        FindPointCorrespondences(model1, model2, {cross_pairs[k]});
    size_t num_rejected_points = 0;
    for (size_t i = 0; i < pair_points.Size(); ++i) {
      num_rejected_points += outcome->rejected_inliers.count(
          {pair_points.point3D_ids1[i], pair_points.point3D_ids2[i]});
    }
    if (2 * num_rejected_points > pair_points.Size()) {
      outcome->false_pairs.push_back(ImagePairToPairId(
          cross_pairs[k].image_id1, cross_pairs[k].image_id2));
    }
  }
}

// The similarity of communities 1 and 2 from the images both models
// registered and their cross edges' matches (read under `database_mutex`).
// RANSAC draws from a seed of the pair's own, so that the outcome depends
// neither on the thread that runs it nor on the order of the pairs.
PairOutcome EstimatePairSimilarity(
    const Database& database,
    std::mutex* database_mutex,
    const std::function<bool(image_t, image_t)>& is_verified_pair,
    const std::function<bool(image_t, image_t)>& is_compared_pair,
    const int community1,
    const int community2,
    const Reconstruction& model1,
    const Reconstruction& model2,
    const std::vector<std::pair<image_t, image_t>>& cross_edges,
    const PairwiseSimilarityOptions& pairwise_options,
    const CovisibilityCheckOptions& covisibility_options) {
  SetPRNGSeed(static_cast<unsigned>(kDefaultPRNGSeed) +
              static_cast<unsigned>(
                  ImagePairToPairId(static_cast<image_t>(community1 + 1),
                                    static_cast<image_t>(community2 + 1))));
  PairOutcome outcome;
  std::vector<CrossPairMatches> cross_pairs =
      SharedImageMatches(model1, model2);
  const size_t num_shared_images = cross_pairs.size();
  {
    std::lock_guard<std::mutex> lock(*database_mutex);
    for (const auto& [image_id1, image_id2] : cross_edges) {
      cross_pairs.push_back(
          {image_id1,
           image_id2,
           database.ReadTwoViewGeometry(image_id1, image_id2).inlier_matches});
    }
  }
  const PointCorrespondences correspondences =
      FindPointCorrespondences(model1, model2, cross_pairs);

  CovisibilityCheck covisibility;
  std::string rejected;
  int num_rejected = 0;
  const PairwiseSimilarity similarity = EstimatePairwiseSimilarity(
      correspondences,
      pairwise_options,
      [&](const PairwiseSimilarity& candidate) {
        covisibility = CheckCovisibility(model1,
                                         model2,
                                         candidate.second_from_first,
                                         is_verified_pair,
                                         is_compared_pair,
                                         covisibility_options);
        if (!covisibility.consistent) {
          outcome.rejected_inliers.insert(candidate.inlier_point3D_ids.begin(),
                                          candidate.inlier_point3D_ids.end());
          rejected += StringPrintf(
              " [%d inliers rejected: co-visible pairs verified %d of %d "
              "across, %d of %d inside]",
              candidate.num_inliers,
              covisibility.cross.num_verified,
              covisibility.cross.num_predicted,
              covisibility.internal.num_verified,
              covisibility.internal.num_predicted);
        }
        return covisibility.consistent;
      },
      &num_rejected);
  SharedImageAgreement agreement;
  int num_explained_cross_pairs = 0;
  if (similarity.success) {
    num_explained_cross_pairs = CountExplainedCrossPairs(
        model1,
        model2,
        similarity.second_from_first,
        {cross_pairs.begin() + num_shared_images, cross_pairs.end()});
    agreement =
        CheckSharedImages(model1,
                          model2,
                          similarity.second_from_first,
                          MedianDistanceToMedian(similarity.inlier_points2));
  }
  outcome.log = StringPrintf(
      "Communities %d-%d: %d shared images, %d cross edges, %d point "
      "correspondences%s -> %s",
      community1,
      community2,
      static_cast<int>(num_shared_images),
      static_cast<int>(cross_edges.size()),
      static_cast<int>(correspondences.Size()),
      rejected.c_str(),
      similarity.success
          ? StringPrintf("%d inliers, %d cross pairs explained, "
                         "scale %.4f, co-visible pairs "
                         "verified %d of %d across, %d of %d inside, "
                         "shared images placed alike %d of %d (largest "
                         "difference %.1f deg, %.2f spreads): used",
                         similarity.num_inliers,
                         num_explained_cross_pairs,
                         similarity.second_from_first.scale(),
                         covisibility.cross.num_verified,
                         covisibility.cross.num_predicted,
                         covisibility.internal.num_verified,
                         covisibility.internal.num_predicted,
                         agreement.num_agreeing,
                         agreement.num_shared_images,
                         agreement.max_rotation_deg,
                         agreement.max_relative_distance)
                .c_str()
      : num_rejected > 0 ? "no transform explains the matches, not used"
                         : "too little support, not used");

  RecordFalseCrossPairs(
      model1, model2, cross_pairs, num_shared_images, &outcome);
  if (!similarity.success) {
    return outcome;
  }
  RelativeSimilarity& relative = outcome.similarity.emplace();
  relative.community1 = community1;
  relative.community2 = community2;
  relative.second_from_first = similarity.second_from_first;
  relative.points1 = similarity.inlier_points1;
  relative.points2 = similarity.inlier_points2;
  relative.num_inliers = similarity.num_inliers;
  relative.num_explained_cross_pairs = num_explained_cross_pairs;
  relative.num_shared_images = agreement.num_shared_images;
  relative.num_agreeing_shared_images = agreement.num_agreeing;
  return outcome;
}

}  // namespace

CommunitySimilarities EstimateCommunitySimilarities(
    const Database& database,
    const ViewGraph& view_graph,
    const CrossEdges& cross_edges,
    const std::vector<std::shared_ptr<const Reconstruction>>& models,
    const PairwiseSimilarityOptions& pairwise_options,
    const CovisibilityCheckOptions& covisibility_options,
    const int num_threads) {
  std::unordered_set<image_pair_t> verified_pairs;
  for (const ViewGraph::Edge& edge : view_graph.Edges()) {
    verified_pairs.insert(
        ImagePairToPairId(view_graph.ImageIds()[edge.vertex1],
                          view_graph.ImageIds()[edge.vertex2]));
  }
  const auto is_verified_pair = [&verified_pairs](const image_t image_id1,
                                                  const image_t image_id2) {
    return verified_pairs.count(ImagePairToPairId(image_id1, image_id2)) > 0;
  };

  // A pair the matcher compared has a two-view geometry, verified or not
  // (covisibility_check.h). A database without a failed pair (e.g. the
  // generated scenes) cannot tell a pair never compared from one that
  // failed: every pair counts as compared, as after exhaustive matching.
  std::mutex database_mutex;
  std::function<bool(image_t, image_t)> is_compared_pair;
  if (view_graph.NumFailedPairs() > 0) {
    is_compared_pair = [&](const image_t image_id1, const image_t image_id2) {
      if (is_verified_pair(image_id1, image_id2)) {
        return true;
      }
      std::lock_guard<std::mutex> lock(database_mutex);
      return database.ExistsTwoViewGeometry(image_id1, image_id2);
    };
  }

  std::vector<const CrossEdges::value_type*> pairs;
  for (const auto& pair_and_edges : cross_edges) {
    THROW_CHECK_LT(pair_and_edges.first.second, models.size());
    if (models[pair_and_edges.first.first] &&
        models[pair_and_edges.first.second]) {
      pairs.push_back(&pair_and_edges);
    }
  }
  // The pairs run in parallel (after dense matching each can hold tens of
  // thousands of correspondences, and RANSAC over them is slow).
  std::vector<PairOutcome> outcomes(pairs.size());
  {
    ThreadPool thread_pool(std::clamp(static_cast<int>(pairs.size()),
                                      1,
                                      GetEffectiveNumThreads(num_threads)));
    for (size_t i = 0; i < pairs.size(); ++i) {
      thread_pool.AddTask([&, i]() {
        const int community1 = pairs[i]->first.first;
        const int community2 = pairs[i]->first.second;
        outcomes[i] = EstimatePairSimilarity(database,
                                             &database_mutex,
                                             is_verified_pair,
                                             is_compared_pair,
                                             community1,
                                             community2,
                                             *models[community1],
                                             *models[community2],
                                             pairs[i]->second,
                                             pairwise_options,
                                             covisibility_options);
      });
    }
    thread_pool.Wait();
  }

  // Logged and gathered in the order of the pairs, whichever finished first.
  CommunitySimilarities result;
  for (PairOutcome& outcome : outcomes) {
    LOG(INFO) << outcome.log;
    result.false_pairs.insert(outcome.false_pairs.begin(),
                              outcome.false_pairs.end());
    if (outcome.similarity) {
      result.similarities.push_back(std::move(*outcome.similarity));
    }
  }
  return result;
}

}  // namespace colmap
