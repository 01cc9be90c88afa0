// Registration of a community model as one block into a merged model.
//
// A part of the merge that no kept similarity joins to the others (its links
// were dropped or never found) is offered to the refinement of a larger
// part, which registers its images one at a time as the incremental mapper
// does (IncrementalMapper::RegisterNextImage with a local bundle adjustment
// after each). That throws away the community's own model, which its mapper
// built and the merge judged sound, and costs a local adjustment per image.
//
// Once the merged model and the community model register a few images in
// common (the controller passes the community's own images only, so these
// are images the refinement registered one by one), their shared images say
// directly where the community model lies: the similarity
// X_merged = s R X_model + t is estimated with LO-RANSAC from the 3D points
// that both models triangulated from the same keypoints of the shared
// images (as CSfM's pairwise similarities, pairwise_similarity.h), and it
// is accepted only if it explains at least `min_inlier_fraction` of those
// points (half by default) and maps every shared image's pose in the
// community model onto its pose in the merged model (CheckSharedImages).
// The model's other images are then registered at once with their poses
// mapped by it (frame by frame: a frame's images share one pose), keeping
// the shape of the community's model, as the similarity averaging would
// have placed it. The refinement's track
// building and bundle adjustments follow as for any joined community.

#pragma once

#include "colmap_ext/sfm/pairwise_similarity.h"

#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"

#include <vector>

namespace colmap {

struct BlockRegistrationOptions {
  // Images both models must have registered before the similarity between
  // them is estimated: with fewer, a wrong transform that happens to fit
  // them is not ruled out by the others (each shared image is one check).
  int min_num_shared_images = 3;

  // Fraction of the corresponding points the similarity must explain. They
  // are the same keypoints triangulated in both models, so a right model
  // agrees on nearly all; where the model is bent or was registered on
  // repeated structure, far fewer agree (docs/design.md).
  double min_inlier_fraction = 0.5;

  // The similarity's estimation and its check of the shared images.
  PairwiseSimilarityOptions similarity;

  bool Check() const;
};

struct BlockRegistration {
  bool success = false;
  // X_merged = s R X_model + t.
  Sim3d merged_from_model;
  int num_shared_images = 0;
  int num_correspondences = 0;
  int num_inliers = 0;
  // The model's registered images that the merged model holds, unregistered:
  // those to register with the transformed poses (whole frames, as the
  // database groups images into frames in both models).
  std::vector<image_t> image_ids;
};

// The similarity that places `model` in the frame of `merged` through the
// images both registered, and the images of `model` it would register there.
BlockRegistration EstimateBlockRegistration(
    const Reconstruction& model,
    const Reconstruction& merged,
    const BlockRegistrationOptions& options);

// Registers the frames of `registration.image_ids` in `merged`, each with
// the pose of its first image in `model` mapped by
// `registration.merged_from_model`. A camera that only images of
// the model use among the registered images of `merged` (the shared images
// registered one by one, if any) takes the model's intrinsics: they were
// refined there over all its images, where the merged model has the
// database's prior or what a few images registered one by one told; a
// camera that other images of `merged` use keeps its intrinsics. The images
// gain no points: triangulating them is the caller's part.
void ApplyBlockRegistration(const Reconstruction& model,
                            const BlockRegistration& registration,
                            Reconstruction* merged);

}  // namespace colmap
