#include "colmap_ext/sfm/block_registration.h"

#include "colmap/geometry/pose.h"
#include "colmap/util/logging.h"

#include <unordered_set>

namespace colmap {

bool BlockRegistrationOptions::Check() const {
  CHECK_OPTION_GE(min_num_shared_images, 1);
  CHECK_OPTION_GE(min_inlier_fraction, 0);
  CHECK_OPTION_LE(min_inlier_fraction, 1);
  CHECK_OPTION(similarity.Check());
  return true;
}

BlockRegistration EstimateBlockRegistration(
    const Reconstruction& model,
    const Reconstruction& merged,
    const BlockRegistrationOptions& options) {
  THROW_CHECK(options.Check());
  BlockRegistration registration;
  // Each shared image is a cross pair of the image with itself, every
  // keypoint matched to itself (FindPointCorrespondences keeps those with a
  // 3D point in both models).
  std::vector<CrossPairMatches> cross_pairs;
  for (const image_t image_id : model.RegImageIds()) {
    if (!merged.ExistsImage(image_id)) {
      continue;
    }
    if (!merged.Image(image_id).HasPose()) {
      registration.image_ids.push_back(image_id);
      continue;
    }
    CrossPairMatches cross_pair;
    cross_pair.image_id1 = image_id;
    cross_pair.image_id2 = image_id;
    const point2D_t num_points2D = model.Image(image_id).NumPoints2D();
    cross_pair.matches.reserve(num_points2D);
    for (point2D_t point2D_idx = 0; point2D_idx < num_points2D; ++point2D_idx) {
      cross_pair.matches.emplace_back(point2D_idx, point2D_idx);
    }
    cross_pairs.push_back(std::move(cross_pair));
  }
  registration.num_shared_images = static_cast<int>(cross_pairs.size());
  if (registration.num_shared_images < options.min_num_shared_images ||
      registration.image_ids.empty()) {
    return registration;
  }

  const PointCorrespondences correspondences =
      FindPointCorrespondences(model, merged, cross_pairs);
  registration.num_correspondences = static_cast<int>(correspondences.Size());
  const double spread = MedianDistanceToMedian(correspondences.points2);
  if (spread <= 0) {
    return registration;
  }
  int num_rejected = 0;
  const PairwiseSimilarity similarity = EstimatePairwiseSimilarity(
      correspondences,
      options.similarity,
      [&](const PairwiseSimilarity& candidate) {
        return candidate.num_inliers >=
                   options.min_inlier_fraction * correspondences.Size() &&
               CheckSharedImages(model,
                                 merged,
                                 candidate.second_from_first,
                                 spread,
                                 options.similarity)
                   .AllAgree();
      },
      &num_rejected);
  registration.num_inliers = similarity.num_inliers;
  if (similarity.success) {
    registration.success = true;
    registration.merged_from_model = similarity.second_from_first;
  }
  return registration;
}

void ApplyBlockRegistration(const Reconstruction& model,
                            const BlockRegistration& registration,
                            Reconstruction* merged) {
  THROW_CHECK(registration.success);
  // Cameras that a registered image of the merged model uses and the model
  // does not hold keep the merged model's intrinsics; the others take the
  // model's.
  std::unordered_set<camera_t> kept_camera_ids;
  for (const image_t image_id : merged->RegImageIds()) {
    if (!model.ExistsImage(image_id) || !model.Image(image_id).HasPose()) {
      kept_camera_ids.insert(merged->Image(image_id).CameraId());
    }
  }
  // Each frame takes the pose of its first image in the model (the frame's
  // images share it); frames registered already stay as they are.
  std::unordered_set<frame_t> registered_frame_ids;
  for (const image_t image_id : registration.image_ids) {
    const Image& model_image = model.Image(image_id);
    const Image& image = merged->Image(image_id);
    THROW_CHECK_EQ(image.CameraId(), model_image.CameraId());
    if (kept_camera_ids.insert(image.CameraId()).second) {
      merged->Camera(image.CameraId()).params =
          model.Camera(image.CameraId()).params;
    }
    Frame& frame = merged->Frame(image.FrameId());
    if (!registered_frame_ids.insert(frame.FrameId()).second) {
      continue;
    }
    THROW_CHECK(!frame.HasPose());
    frame.SetCamFromWorld(image.CameraId(),
                          TransformCameraWorld(registration.merged_from_model,
                                               model_image.CamFromWorld()));
    merged->RegisterFrame(frame.FrameId());
  }
}

}  // namespace colmap
