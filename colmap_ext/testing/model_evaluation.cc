#include "colmap_ext/testing/model_evaluation.h"

#include "colmap/estimators/alignment.h"
#include "colmap/math/math.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <tuple>
#include <unordered_map>
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

// The largest value that is not NaN (NaN if there is none).
double MaxOf(const std::vector<double>& values) {
  double max_value = std::numeric_limits<double>::quiet_NaN();
  for (const double value : values) {
    if (!std::isnan(value) && (std::isnan(max_value) || value > max_value)) {
      max_value = value;
    }
  }
  return max_value;
}

// The pose of a sensor relative to its rig's reference sensor, if known.
std::optional<Rigid3d> MaybeSensorFromRefSensor(const Rig& rig,
                                                const sensor_t& sensor_id) {
  if (rig.IsRefSensor(sensor_id)) {
    return Rigid3d();
  }
  if (rig.HasSensorFromRig(sensor_id)) {
    return rig.SensorFromRig(sensor_id);
  }
  return std::nullopt;
}

// Rotation error (degrees) and baseline error of a model's camera pose
// relative to its reference camera against the true one; `scale` takes the
// model's lengths to the truth's (NaN: unknown).
std::pair<double, double> RelativePoseErrors(const Rigid3d& model_cam_from_ref,
                                             const Rigid3d& true_cam_from_ref,
                                             const double scale) {
  const double rotation_error_deg =
      RadToDeg(true_cam_from_ref.rotation().angularDistance(
          model_cam_from_ref.rotation()));
  const double baseline = true_cam_from_ref.translation().norm();
  const double baseline_error =
      baseline > 0 ? (scale * model_cam_from_ref.translation() -
                      true_cam_from_ref.translation())
                             .norm() /
                         baseline
                   : std::numeric_limits<double>::quiet_NaN();
  return {rotation_error_deg, baseline_error};
}

// The rig figures of `evaluation` (see ModelEvaluation), for the images of
// `shared` (name -> ground-truth and model image).
void EvaluateRigs(
    const Reconstruction& model,
    const Reconstruction& ground_truth,
    const std::map<std::string, std::pair<const Image*, const Image*>>& shared,
    ModelEvaluation* evaluation) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double scale = evaluation->aligned
                           ? evaluation->ground_truth_from_model.scale()
                           : nan;

  // The model's camera of every ground-truth camera with shared images, and
  // the model's image of every shared ground-truth image.
  std::unordered_map<camera_t, camera_t> model_camera_ids;
  std::unordered_map<image_t, const Image*> model_images;
  for (const auto& name_and_images : shared) {
    const auto& [gt_image, model_image] = name_and_images.second;
    model_camera_ids.emplace(gt_image->CameraId(), model_image->CameraId());
    model_images.emplace(gt_image->ImageId(), model_image);
  }

  std::vector<rig_t> rig_ids;
  for (const auto& [rig_id, rig] : ground_truth.Rigs()) {
    if (rig.NumSensors() > 1 && rig.RefSensorId().type == SensorType::CAMERA) {
      rig_ids.push_back(rig_id);
    }
  }
  std::sort(rig_ids.begin(), rig_ids.end());

  for (const rig_t rig_id : rig_ids) {
    const Rig& rig = ground_truth.Rig(rig_id);
    const sensor_t& ref_sensor_id = rig.RefSensorId();
    for (const auto& [sensor_id, true_sensor_from_rig] : rig.NonRefSensors()) {
      if (sensor_id.type != SensorType::CAMERA ||
          !true_sensor_from_rig.has_value()) {
        continue;
      }
      evaluation->rig_camera_ids.push_back(sensor_id.id);
      double rotation_error_deg = nan;
      double baseline_error = nan;

      // A rig of the model that holds both cameras with their poses.
      const auto model_ref_it = model_camera_ids.find(ref_sensor_id.id);
      const auto model_camera_it = model_camera_ids.find(sensor_id.id);
      std::optional<Rigid3d> model_cam_from_ref;
      if (model_ref_it != model_camera_ids.end() &&
          model_camera_it != model_camera_ids.end()) {
        const sensor_t model_ref_sensor_id(SensorType::CAMERA,
                                           model_ref_it->second);
        const sensor_t model_sensor_id(SensorType::CAMERA,
                                       model_camera_it->second);
        for (const auto& [_, model_rig] : model.Rigs()) {
          if (!model_rig.HasSensor(model_ref_sensor_id) ||
              !model_rig.HasSensor(model_sensor_id)) {
            continue;
          }
          const std::optional<Rigid3d> ref_from_rig =
              MaybeSensorFromRefSensor(model_rig, model_ref_sensor_id);
          const std::optional<Rigid3d> cam_from_rig =
              MaybeSensorFromRefSensor(model_rig, model_sensor_id);
          if (ref_from_rig.has_value() && cam_from_rig.has_value()) {
            model_cam_from_ref = *cam_from_rig * Inverse(*ref_from_rig);
          }
          break;
        }
      }

      if (model_cam_from_ref.has_value()) {
        std::tie(rotation_error_deg, baseline_error) = RelativePoseErrors(
            *model_cam_from_ref, *true_sensor_from_rig, scale);
      } else {
        // Otherwise per snapshot of the rig: the model's images of the
        // reference camera and of this one.
        std::vector<double> rotation_errors_deg;
        std::vector<double> baseline_errors;
        for (const frame_t frame_id : ground_truth.RegFrameIds()) {
          const Frame& frame = ground_truth.Frame(frame_id);
          if (frame.RigId() != rig_id) {
            continue;
          }
          const Image* model_ref_image = nullptr;
          const Image* model_image = nullptr;
          for (const data_t& data_id : frame.ImageIds()) {
            const auto it = model_images.find(static_cast<image_t>(data_id.id));
            if (it == model_images.end()) {
              continue;
            }
            if (data_id.sensor_id == ref_sensor_id) {
              model_ref_image = it->second;
            } else if (data_id.sensor_id == sensor_id) {
              model_image = it->second;
            }
          }
          if (model_ref_image == nullptr || model_image == nullptr) {
            continue;
          }
          const auto [frame_rotation_error_deg, frame_baseline_error] =
              RelativePoseErrors(model_image->CamFromWorld() *
                                     Inverse(model_ref_image->CamFromWorld()),
                                 *true_sensor_from_rig,
                                 scale);
          rotation_errors_deg.push_back(frame_rotation_error_deg);
          baseline_errors.push_back(frame_baseline_error);
        }
        rotation_error_deg = Quantile(rotation_errors_deg, 0.5);
        baseline_error = Quantile(baseline_errors, 0.5);
      }
      evaluation->rig_rotation_errors_deg.push_back(rotation_error_deg);
      evaluation->rig_baseline_errors.push_back(baseline_error);
    }
  }
  evaluation->rig_rotation_error_deg =
      MaxOf(evaluation->rig_rotation_errors_deg);
  evaluation->rig_baseline_error_fraction =
      MaxOf(evaluation->rig_baseline_errors);
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
    if (model_image != nullptr && model_image->HasPose()) {
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
  if (shared.size() >= 3 && evaluation.extent > 0) {
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
  }

  if (evaluation.aligned) {
    const Sim3d& gt_from_model = evaluation.ground_truth_from_model;
    for (const auto& name_and_images : shared) {
      const Image& gt_image = *name_and_images.second.first;
      const Image& model_image = *name_and_images.second.second;
      const Eigen::Vector3d aligned_center =
          gt_from_model * model_image.ProjectionCenter();
      const Eigen::Quaterniond aligned_cam_from_world =
          model_image.CamFromWorld().rotation() *
          gt_from_model.rotation().inverse();
      evaluation.image_names.push_back(name_and_images.first);
      evaluation.aligned_centers.push_back(aligned_center);
      evaluation.ground_truth_centers.push_back(gt_image.ProjectionCenter());
      evaluation.position_errors.push_back(
          (aligned_center - gt_image.ProjectionCenter()).norm());
      evaluation.rotation_errors_deg.push_back(
          RadToDeg(gt_image.CamFromWorld().rotation().angularDistance(
              aligned_cam_from_world)));
    }
    evaluation.median_position_error =
        Quantile(evaluation.position_errors, 0.5);
    evaluation.p90_position_error = Quantile(evaluation.position_errors, 0.9);
    evaluation.max_position_error = Quantile(evaluation.position_errors, 1.0);
    evaluation.median_rotation_error_deg =
        Quantile(evaluation.rotation_errors_deg, 0.5);
  }

  // The relative poses of the rigs' cameras need no alignment but its scale.
  EvaluateRigs(model, ground_truth, shared, &evaluation);
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
  // Only for a ground truth with multi-camera rigs.
  if (!evaluation.rig_camera_ids.empty()) {
    text += StringPrintf("rig_rotation_error_deg %.6f\n",
                         evaluation.rig_rotation_error_deg);
    text += StringPrintf("rig_baseline_error_fraction %.8f\n",
                         evaluation.rig_baseline_error_fraction);
  }
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
