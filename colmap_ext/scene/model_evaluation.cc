#include "colmap_ext/scene/model_evaluation.h"

#include "colmap/estimators/alignment.h"
#include "colmap/util/logging.h"
#include "colmap/util/misc.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_set>

namespace colmap {
namespace {

double Quantile(std::vector<double> values, const double q) {
  if (values.empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const size_t index = std::min(
      values.size() - 1,
      static_cast<size_t>(std::ceil(q * values.size())) - (q > 0 ? 1 : 0));
  std::nth_element(values.begin(), values.begin() + index, values.end());
  return values[index];
}

}  // namespace

bool ModelEvaluationOptions::Check() const {
  CHECK_OPTION_GT(alignment_max_error_fraction, 0);
  return true;
}

ModelEvaluation EvaluateModel(const Reconstruction& model,
                              const Reconstruction& ground_truth,
                              const ModelEvaluationOptions& options) {
  THROW_CHECK(options.Check());
  ModelEvaluation evaluation;
  evaluation.num_ground_truth_images =
      static_cast<int>(ground_truth.NumRegImages());
  evaluation.num_points3D = static_cast<int>(model.NumPoints3D());
  evaluation.mean_reprojection_error = model.ComputeMeanReprojectionError();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  evaluation.median_position_error = nan;
  evaluation.p90_position_error = nan;
  evaluation.max_position_error = nan;
  evaluation.median_rotation_error_deg = nan;

  // Shared registered images (of `options.image_names`), by name.
  const std::unordered_set<std::string> selected(options.image_names.begin(),
                                                 options.image_names.end());
  std::map<std::string, std::pair<const Image*, const Image*>> shared;
  Eigen::Vector3d min_corner =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
  Eigen::Vector3d max_corner = -min_corner;
  for (const image_t image_id : ground_truth.RegImageIds()) {
    const Image& gt_image = ground_truth.Image(image_id);
    const Eigen::Vector3d center = gt_image.ProjectionCenter();
    min_corner = min_corner.cwiseMin(center);
    max_corner = max_corner.cwiseMax(center);
    if (!selected.empty() && selected.count(gt_image.Name()) == 0) {
      continue;
    }
    const Image* model_image = model.FindImageWithName(gt_image.Name());
    if (model_image != nullptr && model_image->IsRegistered()) {
      shared.emplace(gt_image.Name(), std::make_pair(&gt_image, model_image));
    }
  }
  evaluation.num_registered_images = static_cast<int>(shared.size());
  if (ground_truth.NumRegImages() > 0) {
    evaluation.extent = (max_corner - min_corner).norm();
  }

  std::vector<std::string> names;
  std::vector<Eigen::Vector3d> gt_centers;
  for (const auto& name_and_images : shared) {
    names.push_back(name_and_images.first);
    gt_centers.push_back(name_and_images.second.first->ProjectionCenter());
  }
  if (shared.size() < 3 || evaluation.extent <= 0) {
    return evaluation;
  }

  RANSACOptions ransac_options;
  ransac_options.max_error =
      options.alignment_max_error_fraction * evaluation.extent;
  evaluation.aligned =
      AlignReconstructionToLocations(model,
                                     names,
                                     gt_centers,
                                     /*min_common_images=*/3,
                                     ransac_options,
                                     &evaluation.ground_truth_from_model);
  if (!evaluation.aligned) {
    return evaluation;
  }

  const Sim3d& gt_from_model = evaluation.ground_truth_from_model;
  for (const auto& name_and_images : shared) {
    const Image& gt_image = *name_and_images.second.first;
    const Image& model_image = *name_and_images.second.second;
    const Eigen::Vector3d aligned_center =
        gt_from_model * model_image.ProjectionCenter();
    const Eigen::Quaterniond aligned_cam_from_world =
        model_image.CamFromWorld().rotation * gt_from_model.rotation.inverse();
    evaluation.image_names.push_back(name_and_images.first);
    evaluation.aligned_centers.push_back(aligned_center);
    evaluation.ground_truth_centers.push_back(gt_image.ProjectionCenter());
    evaluation.position_errors.push_back(
        (aligned_center - gt_image.ProjectionCenter()).norm());
    evaluation.rotation_errors_deg.push_back(
        RadToDeg(gt_image.CamFromWorld().rotation.angularDistance(
            aligned_cam_from_world)));
  }
  evaluation.median_position_error = Quantile(evaluation.position_errors, 0.5);
  evaluation.p90_position_error = Quantile(evaluation.position_errors, 0.9);
  evaluation.max_position_error = Quantile(evaluation.position_errors, 1.0);
  evaluation.median_rotation_error_deg =
      Quantile(evaluation.rotation_errors_deg, 0.5);
  return evaluation;
}

std::string ModelEvaluationToString(const ModelEvaluation& evaluation) {
  const double extent = evaluation.extent > 0 ? evaluation.extent : 1.0;
  std::string text;
  text += StringPrintf("ground_truth_images %d\n",
                       evaluation.num_ground_truth_images);
  text +=
      StringPrintf("registered_images %d\n", evaluation.num_registered_images);
  text += StringPrintf("points3D %d\n", evaluation.num_points3D);
  text += StringPrintf("mean_reprojection_error_px %.6f\n",
                       evaluation.mean_reprojection_error);
  text += StringPrintf("aligned %d\n", evaluation.aligned ? 1 : 0);
  text += StringPrintf("extent %.6f\n", evaluation.extent);
  text += StringPrintf("median_position_error %.6f\n",
                       evaluation.median_position_error);
  text +=
      StringPrintf("p90_position_error %.6f\n", evaluation.p90_position_error);
  text +=
      StringPrintf("max_position_error %.6f\n", evaluation.max_position_error);
  text += StringPrintf("median_position_error_fraction %.8f\n",
                       evaluation.median_position_error / extent);
  text += StringPrintf("p90_position_error_fraction %.8f\n",
                       evaluation.p90_position_error / extent);
  text += StringPrintf("median_rotation_error_deg %.6f\n",
                       evaluation.median_rotation_error_deg);
  return text;
}

std::string AlignedCentersToString(const ModelEvaluation& evaluation) {
  std::string text = "# IMAGE_NAME X Y Z GT_X GT_Y GT_Z\n";
  for (size_t i = 0; i < evaluation.image_names.size(); ++i) {
    const Eigen::Vector3d& center = evaluation.aligned_centers[i];
    const Eigen::Vector3d& truth = evaluation.ground_truth_centers[i];
    text += StringPrintf("%s %.6f %.6f %.6f %.6f %.6f %.6f\n",
                         evaluation.image_names[i].c_str(),
                         center.x(),
                         center.y(),
                         center.z(),
                         truth.x(),
                         truth.y(),
                         truth.z());
  }
  return text;
}

}  // namespace colmap
