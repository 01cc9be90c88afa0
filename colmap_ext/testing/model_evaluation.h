// Accuracy of a sparse model against ground-truth cameras.
//
// The model's camera centres are aligned to the ground truth's by a robust
// similarity transform (LO-RANSAC over the images both share, inlier
// threshold a fraction of the ground truth's extent), then every shared
// image's position error |C_gt - T(C_model)| and rotation error (angle of
// R_gt R_model'^T, R_model' the rotation after alignment) are measured. The
// extent is the diagonal of the bounding box of the ground-truth camera
// centres. Images are matched by name.
//
// For a ground truth with multi-camera rigs, the model's calibration of each
// rig is measured too: the pose of every non-reference camera relative to
// its rig's reference camera (its sensor_from_rig), from the model's rig
// holding both cameras or, where the model has none (e.g. its images are in
// frames of their own), from the poses of the model's images of every
// snapshot of the rig.

#pragma once

#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"

#include <string>
#include <vector>

namespace colmap {

struct ModelEvaluationOptions {
  // Inlier threshold of the robust alignment, as a fraction of the extent.
  double alignment_max_error_fraction = 0.05;

  // Only these images (by name) are aligned and measured, e.g. one
  // community's, to tell a merged model's error from its communities' own;
  // empty: every image the model and the ground truth share. The extent
  // stays the whole ground truth's; num_registered_images counts these
  // images alone.
  std::vector<std::string> image_names;

  bool Check() const;
};

struct ModelEvaluation {
  int num_ground_truth_images = 0;
  // Registered images of the model that the ground truth also has.
  int num_registered_images = 0;
  int num_points3D = 0;
  double mean_reprojection_error = 0.0;

  // Whether a similarity alignment was found (needs 3 shared images).
  bool aligned = false;
  Sim3d ground_truth_from_model;
  double extent = 0.0;
  // Over all shared registered images (NaN when not aligned).
  double median_position_error = 0.0;
  double p90_position_error = 0.0;
  double max_position_error = 0.0;
  double median_rotation_error_deg = 0.0;

  // Per shared image, in the order of image names.
  std::vector<std::string> image_names;
  std::vector<double> position_errors;
  std::vector<double> rotation_errors_deg;
  // Camera centres of the model after the alignment, and of the truth.
  std::vector<Eigen::Vector3d> aligned_centers;
  std::vector<Eigen::Vector3d> ground_truth_centers;

  // Per non-reference camera of the ground truth's rigs with more than one
  // sensor (none: no rig figures), in the order of rig and camera ids: the
  // error of the model's pose of the camera relative to its rig's
  // reference camera, its rotation error (degrees) and its translation
  // error relative to the true baseline, |t_model * s - t_true| / |t_true|
  // (s the scale of ground_truth_from_model). Cameras are matched by the
  // names of their images. The model's relative pose is its rig's if a rig
  // of the model holds both cameras with their poses; otherwise the errors
  // are the medians over the ground truth's frames of the errors of the
  // relative pose of the model's images of each frame. NaN where the model
  // has neither (the baseline error also when not aligned).
  std::vector<camera_t> rig_camera_ids;
  std::vector<double> rig_rotation_errors_deg;
  std::vector<double> rig_baseline_errors;
  // The largest of those errors (NaN when none was measured).
  double rig_rotation_error_deg = 0.0;
  double rig_baseline_error_fraction = 0.0;
};

ModelEvaluation EvaluateModel(const Reconstruction& model,
                              const Reconstruction& ground_truth,
                              const ModelEvaluationOptions& options = {});

// "key value" lines, one figure per line, for scripts to read.
std::string ModelEvaluationToString(const ModelEvaluation& evaluation);

// "IMAGE_NAME X Y Z GT_X GT_Y GT_Z" lines: aligned and true camera centres.
std::string AlignedCentersToString(const ModelEvaluation& evaluation);

}  // namespace colmap
