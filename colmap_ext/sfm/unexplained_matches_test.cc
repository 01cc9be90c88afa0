#include "colmap_ext/sfm/unexplained_matches.h"

#include "colmap_ext/scene/synthetic_scene.h"
#include "colmap_ext/util/testing.h"

#include "colmap/estimators/two_view_geometry.h"

#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// The matches a matcher would find: every two keypoints observing one point
// of the scene's ground truth, plus `extra` pairs of matches.
CorrespondenceGraph TrueMatches(
    const Reconstruction& ground_truth,
    const std::map<image_pair_t, FeatureMatches>& extra = {}) {
  std::map<image_pair_t, FeatureMatches> matches = extra;
  for (const auto& [_, point3D] : ground_truth.Points3D()) {
    const std::vector<TrackElement>& elements = point3D.track.Elements();
    for (size_t i = 0; i < elements.size(); ++i) {
      for (size_t j = i + 1; j < elements.size(); ++j) {
        const bool ordered = elements[i].image_id < elements[j].image_id;
        const TrackElement& first = ordered ? elements[i] : elements[j];
        const TrackElement& second = ordered ? elements[j] : elements[i];
        matches[ImagePairToPairId(first.image_id, second.image_id)]
            .emplace_back(first.point2D_idx, second.point2D_idx);
      }
    }
  }
  CorrespondenceGraph graph;
  for (const auto& [image_id, image] : ground_truth.Images()) {
    graph.AddImage(image_id, image.NumPoints2D());
  }
  for (auto& [pair_id, pair_matches] : matches) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    TwoViewGeometry geometry;
    geometry.config = TwoViewGeometry::CALIBRATED;
    geometry.inlier_matches = std::move(pair_matches);
    graph.AddTwoViewGeometry(image_id1, image_id2, std::move(geometry));
  }
  graph.Finalize();
  return graph;
}

class UnexplainedMatchesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::set<image_t> others;
    std::set<image_t> cluster1;
    SynthesizeTwoLandmarks(
        /*single_camera=*/true, &scene_, &others, &cluster1);
    others_.assign(others.begin(), others.end());
    cluster1_.assign(cluster1.begin(), cluster1.end());
  }

  SyntheticScene scene_;
  std::vector<image_t> cluster1_;
  std::vector<image_t> others_;
};

TEST_F(UnexplainedMatchesTest, RightModelKeepsEveryImage) {
  EXPECT_TRUE(FindImagesApartFromTheirMatches(scene_.ground_truth,
                                              TrueMatches(scene_.ground_truth))
                  .empty());
}

TEST_F(UnexplainedMatchesTest, FalsePairDoesNotCutImagesOff) {
  // Wrong matches between observed keypoints of two images far apart: the
  // pair is not explained, but each image has pairs that are.
  const image_t image_id1 = others_.front();
  const image_t image_id2 = cluster1_.back();
  const Image& image1 = scene_.ground_truth.Image(image_id1);
  const Image& image2 = scene_.ground_truth.Image(image_id2);
  std::vector<point2D_t> observed1;
  std::vector<point2D_t> observed2;
  for (point2D_t idx = 0; idx < image1.NumPoints2D(); ++idx) {
    if (image1.Point2D(idx).HasPoint3D()) {
      observed1.push_back(idx);
    }
  }
  for (point2D_t idx = 0; idx < image2.NumPoints2D(); ++idx) {
    if (image2.Point2D(idx).HasPoint3D()) {
      observed2.push_back(idx);
    }
  }
  FeatureMatches false_matches;
  for (size_t k = 0; k < 40 && k < observed1.size() && k < observed2.size();
       ++k) {
    false_matches.emplace_back(observed1[k], observed2[k]);
  }
  ASSERT_EQ(false_matches.size(), 40);
  ASSERT_LT(image_id1, image_id2);
  const CorrespondenceGraph graph =
      TrueMatches(scene_.ground_truth,
                  {{ImagePairToPairId(image_id1, image_id2), false_matches}});
  EXPECT_TRUE(
      FindImagesApartFromTheirMatches(scene_.ground_truth, graph).empty());
}

TEST_F(UnexplainedMatchesTest, GroupMisplacedWithItsPointsIsFound) {
  // Four images of cluster 1 placed 30 units off with their own copy of
  // every point they see, as a community's mapper registers a stretch onto
  // a look-alike structure: they fit their observations, but their matches
  // with the other images observe other points.
  const std::vector<image_t> misplaced(cluster1_.begin() + 8,
                                       cluster1_.begin() + 12);
  Reconstruction model = scene_.ground_truth;
  MoveImagesWithTheirPoints(
      {misplaced.begin(), misplaced.end()}, Eigen::Vector3d(30, 0, 0), &model);
  EXPECT_EQ(
      FindImagesApartFromTheirMatches(model, TrueMatches(scene_.ground_truth)),
      misplaced);
}

TEST_F(UnexplainedMatchesTest, GroupWithoutObservedMatchesToTheRestStays) {
  // The link's images lose every point: the clusters are two groups that no
  // pair with observed matches joins, neither contradicted by its matches.
  Reconstruction model = scene_.ground_truth;
  for (const auto& [image_id, cluster] : scene_.image_cluster) {
    if (cluster != -1) {
      continue;
    }
    const Image& image = model.Image(image_id);
    for (point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
      if (model.Image(image_id).Point2D(idx).HasPoint3D()) {
        model.DeleteObservation(image_id, idx);
      }
    }
  }
  // Points seen by both clusters would still join them: none is.
  for (const auto& [_, point3D] : model.Points3D()) {
    std::set<int> clusters;
    for (const TrackElement& element : point3D.track.Elements()) {
      clusters.insert(scene_.image_cluster.at(element.image_id));
    }
    ASSERT_EQ(clusters.size(), 1);
  }
  EXPECT_TRUE(
      FindImagesApartFromTheirMatches(model, TrueMatches(scene_.ground_truth))
          .empty());
}

}  // namespace
}  // namespace colmap
