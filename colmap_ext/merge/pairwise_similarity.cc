#include "colmap_ext/merge/pairwise_similarity.h"
#include "colmap_ext/util/option_check.h"

#include "colmap/estimators/solvers/similarity_transform.h"
#include "colmap/estimators/two_view_geometry.h"
#include "colmap/geometry/essential_matrix.h"
#include "colmap/math/math.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <set>

namespace colmap {
namespace {

// Whether both keypoints of `match` exist: COLMAP's correspondence graph
// skips a match whose index is beyond its image's keypoints.
bool HasKeypoints(const Image& image1,
                  const Image& image2,
                  const FeatureMatch& match) {
  return match.point2D_idx1 < image1.NumPoints2D() &&
         match.point2D_idx2 < image2.NumPoints2D();
}

}  // namespace

Eigen::Vector3d CoordinateWiseMedian(
    const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d median;
  std::vector<double> values(points.size());
  for (int d = 0; d < 3; ++d) {
    for (size_t i = 0; i < points.size(); ++i) {
      values[i] = points[i](d);
    }
    std::nth_element(
        values.begin(), values.begin() + values.size() / 2, values.end());
    median(d) = values[values.size() / 2];
  }
  return median;
}

double MedianDistanceToMedian(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) {
    return 0.0;
  }
  const Eigen::Vector3d median = CoordinateWiseMedian(points);
  std::vector<double> values(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    values[i] = (points[i] - median).norm();
  }
  std::nth_element(
      values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

PointCorrespondences FindPointCorrespondences(
    const Reconstruction& reconstruction1,
    const Reconstruction& reconstruction2,
    const std::vector<CrossPairMatches>& cross_pairs) {
  std::set<std::pair<point3D_t, point3D_t>> point3D_pairs;
  for (const CrossPairMatches& cross_pair : cross_pairs) {
    if (!HasPosedImage(reconstruction1, cross_pair.image_id1) ||
        !HasPosedImage(reconstruction2, cross_pair.image_id2)) {
      continue;
    }
    const Image& image1 = reconstruction1.Image(cross_pair.image_id1);
    const Image& image2 = reconstruction2.Image(cross_pair.image_id2);
    for (const FeatureMatch& match : cross_pair.matches) {
      if (!HasKeypoints(image1, image2, match)) {
        continue;
      }
      const Point2D& point2D1 = image1.Point2D(match.point2D_idx1);
      const Point2D& point2D2 = image2.Point2D(match.point2D_idx2);
      if (point2D1.HasPoint3D() && point2D2.HasPoint3D()) {
        point3D_pairs.emplace(point2D1.point3D_id, point2D2.point3D_id);
      }
    }
  }

  PointCorrespondences correspondences;
  for (const auto& point3D_pair : point3D_pairs) {
    correspondences.point3D_ids1.push_back(point3D_pair.first);
    correspondences.point3D_ids2.push_back(point3D_pair.second);
    correspondences.points1.push_back(
        reconstruction1.Point3D(point3D_pair.first).xyz);
    correspondences.points2.push_back(
        reconstruction2.Point3D(point3D_pair.second).xyz);
  }
  return correspondences;
}

bool PairwiseSimilarityOptions::Check() const {
  if (!CheckFlag(max_relative_error > 0,
                 "pairwise_max_relative_error",
                 max_relative_error,
                 "positive") ||
      !CheckFlag(min_num_inliers >= 3,
                 "pairwise_min_num_inliers",
                 min_num_inliers,
                 "at least 3")) {
    return false;
  }
  CHECK_OPTION_GE(max_num_hypotheses, 1);
  return true;
}

PairwiseSimilarity EstimatePairwiseSimilarity(
    const PointCorrespondences& correspondences,
    const PairwiseSimilarityOptions& options) {
  THROW_CHECK(options.Check());
  PairwiseSimilarity result;
  if (correspondences.Size() < static_cast<size_t>(options.min_num_inliers)) {
    return result;
  }

  const double spread = MedianDistanceToMedian(correspondences.points2);
  if (spread <= 0) {
    return result;
  }

  RANSACOptions ransac_options;
  ransac_options.max_error = options.max_relative_error * spread;
  // A lower bound of the inlier ratio, which bounds the number of trials.
  ransac_options.min_inlier_ratio = 0.1;
  ransac_options.max_num_trials = 10000;
  const auto report = EstimateSim3dRobust(correspondences.points1,
                                          correspondences.points2,
                                          ransac_options,
                                          result.second_from_first);
  if (!report.success) {
    return result;
  }

  result.num_inliers = static_cast<int>(report.support.num_inliers);
  for (size_t i = 0; i < correspondences.Size(); ++i) {
    if (report.inlier_mask[i]) {
      result.inlier_points1.push_back(correspondences.points1[i]);
      result.inlier_points2.push_back(correspondences.points2[i]);
      result.inlier_point3D_ids.emplace_back(correspondences.point3D_ids1[i],
                                             correspondences.point3D_ids2[i]);
    }
  }
  result.success = result.num_inliers >= options.min_num_inliers;
  return result;
}

PairwiseSimilarity EstimatePairwiseSimilarity(
    const PointCorrespondences& correspondences,
    const PairwiseSimilarityOptions& options,
    const std::function<bool(const PairwiseSimilarity&)>& accept,
    int* num_rejected) {
  THROW_CHECK_NOTNULL(num_rejected);
  *num_rejected = 0;
  PointCorrespondences remaining = correspondences;
  PairwiseSimilarity similarity;
  for (int hypothesis = 0; hypothesis < options.max_num_hypotheses;
       ++hypothesis) {
    similarity = EstimatePairwiseSimilarity(remaining, options);
    if (!similarity.success) {
      break;
    }
    if (accept(similarity)) {
      return similarity;
    }
    ++*num_rejected;
    const std::set<std::pair<point3D_t, point3D_t>> inliers(
        similarity.inlier_point3D_ids.begin(),
        similarity.inlier_point3D_ids.end());
    PointCorrespondences outliers;
    for (size_t i = 0; i < remaining.Size(); ++i) {
      if (inliers.count(
              {remaining.point3D_ids1[i], remaining.point3D_ids2[i]}) == 0) {
        outliers.point3D_ids1.push_back(remaining.point3D_ids1[i]);
        outliers.point3D_ids2.push_back(remaining.point3D_ids2[i]);
        outliers.points1.push_back(remaining.points1[i]);
        outliers.points2.push_back(remaining.points2[i]);
      }
    }
    remaining = std::move(outliers);
  }
  similarity.success = false;
  return similarity;
}

SharedImageAgreement CheckSharedImages(const Reconstruction& reconstruction1,
                                       const Reconstruction& reconstruction2,
                                       const Sim3d& second_from_first,
                                       const double spread) {
  constexpr double kMaxRotationDeg = 10.0;
  constexpr double kMaxRelativeDistance = 1.0;
  THROW_CHECK_GT(spread, 0);
  SharedImageAgreement agreement;
  for (const image_t image_id : reconstruction1.RegImageIds()) {
    if (!HasPosedImage(reconstruction2, image_id)) {
      continue;
    }
    const Image& image1 = reconstruction1.Image(image_id);
    const Image& image2 = reconstruction2.Image(image_id);
    // The pose in the second model that the transform predicts.
    const Eigen::Quaterniond predicted_rotation =
        image1.CamFromWorld().rotation() *
        second_from_first.rotation().inverse();
    const Eigen::Vector3d predicted_center =
        second_from_first * image1.ProjectionCenter();
    const double rotation_deg = RadToDeg(
        predicted_rotation.angularDistance(image2.CamFromWorld().rotation()));
    const double relative_distance =
        (predicted_center - image2.ProjectionCenter()).norm() / spread;
    ++agreement.num_shared_images;
    if (rotation_deg <= kMaxRotationDeg &&
        relative_distance <= kMaxRelativeDistance) {
      ++agreement.num_agreeing;
    }
    agreement.max_rotation_deg =
        std::max(agreement.max_rotation_deg, rotation_deg);
    agreement.max_relative_distance =
        std::max(agreement.max_relative_distance, relative_distance);
  }
  return agreement;
}

int CountExplainedCrossPairs(const Reconstruction& reconstruction1,
                             const Reconstruction& reconstruction2,
                             const Sim3d& second_from_first,
                             const std::vector<CrossPairMatches>& cross_pairs) {
  const double max_error = TwoViewGeometryOptions().ransac_options.max_error;
  int num_explained = 0;
  for (const CrossPairMatches& pair : cross_pairs) {
    if (!HasPosedImage(reconstruction1, pair.image_id1) ||
        !HasPosedImage(reconstruction2, pair.image_id2)) {
      continue;
    }
    const Image& image1 = reconstruction1.Image(pair.image_id1);
    const Image& image2 = reconstruction2.Image(pair.image_id2);
    // cam2_from_cam1, in the second model's units.
    const Rigid3d cam2_from_world2 = image2.CamFromWorld();
    const Eigen::Matrix3d E = EssentialMatrixFromPose(Rigid3d(
        cam2_from_world2.rotation() * second_from_first.rotation() *
            image1.CamFromWorld().rotation().inverse(),
        cam2_from_world2 * (second_from_first * image1.ProjectionCenter())));
    const double max_residual =
        std::pow(0.5 * (image1.CameraPtr()->CamFromImgThreshold(max_error) +
                        image2.CameraPtr()->CamFromImgThreshold(max_error)),
                 2);
    size_t num_within = 0;
    for (const FeatureMatch& match : pair.matches) {
      if (!HasKeypoints(image1, image2, match)) {
        continue;
      }
      const std::optional<Eigen::Vector2d> point1 =
          image1.CameraPtr()->CamFromImg(image1.Point2D(match.point2D_idx1).xy);
      const std::optional<Eigen::Vector2d> point2 =
          image2.CameraPtr()->CamFromImg(image2.Point2D(match.point2D_idx2).xy);
      num_within +=
          point1 && point2 &&
          ComputeSquaredSampsonError(
              point1->homogeneous(), point2->homogeneous(), E) <= max_residual;
    }
    num_explained += 2 * num_within > pair.matches.size();
  }
  return num_explained;
}

}  // namespace colmap
