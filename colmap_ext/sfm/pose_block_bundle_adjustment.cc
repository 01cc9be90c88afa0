#include "colmap_ext/sfm/pose_block_bundle_adjustment.h"

#include "colmap/estimators/cost_functions.h"
#include "colmap/util/logging.h"
#include "colmap/util/threading.h"

#include <algorithm>
#include <string>
#include <vector>

#include <ceres/product_manifold.h>

namespace colmap {
namespace {

// COLMAP's reprojection error (ReprojErrorCostFunction) with the pose as
// one parameter block: the rotation's quaternion (x, y, z, w), then the
// translation.
template <typename CameraModel>
class PoseBlockReprojErrorCostFunction {
 public:
  explicit PoseBlockReprojErrorCostFunction(const Eigen::Vector2d& point2D)
      : error_(point2D) {}

  static ceres::CostFunction* Create(const Eigen::Vector2d& point2D) {
    return new ceres::AutoDiffCostFunction<
        PoseBlockReprojErrorCostFunction<CameraModel>,
        2,
        7,
        3,
        CameraModel::num_params>(new PoseBlockReprojErrorCostFunction(point2D));
  }

  template <typename T>
  bool operator()(const T* const cam_from_world,
                  const T* const point3D,
                  const T* const camera_params,
                  T* residuals) const {
    return error_(
        cam_from_world, cam_from_world + 4, point3D, camera_params, residuals);
  }

 private:
  const ReprojErrorCostFunction<CameraModel> error_;
};

}  // namespace

PoseBlockBundleAdjuster::PoseBlockBundleAdjuster(
    const BundleAdjustmentOptions& options,
    const BundleAdjustmentConfig& config)
    : options_(options), config_(config) {
  THROW_CHECK(options_.Check());
  THROW_CHECK_EQ(config_.NumPoints(), 0)
      << "PoseBlockBundleAdjuster takes configurations of images only";
}

void PoseBlockBundleAdjuster::SetUpProblem(
    Reconstruction* reconstruction,
    const std::unordered_set<point3D_t>* point3D_ids) {
  THROW_CHECK_NOTNULL(reconstruction);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
  loss_function_.reset(options_.CreateLossFunction());
  poses_.clear();

  std::unordered_set<camera_t> camera_ids;
  std::unordered_map<point3D_t, size_t> num_point3D_observations;
  for (const image_t image_id : config_.Images()) {
    Image& image = reconstruction->Image(image_id);
    Camera& camera = reconstruction->Camera(image.CameraId());
    Rigid3d& cam_from_world = image.CamFromWorld();
    // The cost functions assume unit quaternions.
    cam_from_world.rotation.normalize();
    const bool constant_pose =
        !options_.refine_extrinsics || config_.HasConstantCamPose(image_id);
    double* pose = nullptr;
    size_t num_observations = 0;
    for (const Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D() ||
          (point3D_ids != nullptr &&
           point3D_ids->count(point2D.point3D_id) == 0)) {
        continue;
      }
      ++num_observations;
      ++num_point3D_observations[point2D.point3D_id];
      Point3D& point3D = reconstruction->Point3D(point2D.point3D_id);
      if (constant_pose) {
        problem_->AddResidualBlock(
            CameraCostFunction<ReprojErrorConstantPoseCostFunction>(
                camera.model_id, cam_from_world, point2D.xy),
            loss_function_.get(),
            point3D.xyz.data(),
            camera.params.data());
        continue;
      }
      if (pose == nullptr) {
        pose = poses_[image_id].data();
        std::copy_n(cam_from_world.rotation.coeffs().data(), 4, pose);
        std::copy_n(cam_from_world.translation.data(), 3, pose + 4);
      }
      problem_->AddResidualBlock(
          CameraCostFunction<PoseBlockReprojErrorCostFunction>(camera.model_id,
                                                               point2D.xy),
          loss_function_.get(),
          pose,
          point3D.xyz.data(),
          camera.params.data());
    }
    if (num_observations > 0) {
      camera_ids.insert(image.CameraId());
    }
    if (pose == nullptr) {
      continue;
    }
    if (config_.HasConstantCamPositions(image_id)) {
      problem_->SetManifold(
          pose,
          new ceres::ProductManifold<ceres::EigenQuaternionManifold,
                                     ceres::SubsetManifold>(
              ceres::EigenQuaternionManifold(),
              ceres::SubsetManifold(3,
                                    config_.ConstantCamPositions(image_id))));
    } else {
      problem_->SetManifold(
          pose,
          new ceres::ProductManifold<ceres::EigenQuaternionManifold,
                                     ceres::EuclideanManifold<3>>());
    }
  }

  // The intrinsics the options or the configuration hold.
  for (const camera_t camera_id : camera_ids) {
    Camera& camera = reconstruction->Camera(camera_id);
    std::vector<int> constant_params;
    auto hold = [&constant_params](const span<const size_t> idxs) {
      constant_params.insert(constant_params.end(), idxs.begin(), idxs.end());
    };
    if (!options_.refine_focal_length) hold(camera.FocalLengthIdxs());
    if (!options_.refine_principal_point) hold(camera.PrincipalPointIdxs());
    if (!options_.refine_extra_params) hold(camera.ExtraParamsIdxs());
    if (config_.HasConstantCamIntrinsics(camera_id) ||
        constant_params.size() == camera.params.size()) {
      problem_->SetParameterBlockConstant(camera.params.data());
    } else if (!constant_params.empty()) {
      SetSubsetManifold(static_cast<int>(camera.params.size()),
                        constant_params,
                        problem_.get(),
                        camera.params.data());
    }
  }
  // A point also observed outside the problem is held there.
  for (const auto& [point3D_id, num_observations] : num_point3D_observations) {
    Point3D& point3D = reconstruction->Point3D(point3D_id);
    if (point3D.track.Length() > num_observations) {
      problem_->SetParameterBlockConstant(point3D.xyz.data());
    }
  }
}

const ceres::Problem& PoseBlockBundleAdjuster::Problem() const {
  THROW_CHECK_NOTNULL(problem_);
  return *problem_;
}

ceres::Solver::Summary PoseBlockBundleAdjuster::Solve(
    ceres::Solver::Options solver_options, Reconstruction* reconstruction) {
  THROW_CHECK_NOTNULL(problem_);
  THROW_CHECK_NOTNULL(reconstruction);
  solver_options.num_threads =
      GetEffectiveNumThreads(solver_options.num_threads);
  std::string solver_error;
  THROW_CHECK(solver_options.IsValid(&solver_error)) << solver_error;
  ceres::Solver::Summary summary;
  if (problem_->NumResiduals() == 0) {
    summary.message = "no observations";
    return summary;
  }
  ceres::Solve(solver_options, problem_.get(), &summary);
  for (const auto& [image_id, pose] : poses_) {
    Rigid3d& cam_from_world = reconstruction->Image(image_id).CamFromWorld();
    std::copy_n(pose.data(), 4, cam_from_world.rotation.coeffs().data());
    std::copy_n(pose.data() + 4, 3, cam_from_world.translation.data());
  }
  return summary;
}

BundleAdjustmentConfig MappersGauge(const Reconstruction& reconstruction) {
  const std::vector<image_t>& reg_image_ids = reconstruction.RegImageIds();
  THROW_CHECK_GE(reg_image_ids.size(), 2);
  BundleAdjustmentConfig config;
  for (const image_t image_id : reg_image_ids) {
    config.AddImage(image_id);
  }
  config.SetConstantCamPose(reg_image_ids[0]);
  config.SetConstantCamPositions(reg_image_ids[1], {0});
  return config;
}

bool AdjustGlobalBundleWithPoseBlocks(const BundleAdjustmentOptions& options,
                                      const BundleAdjustmentConfig& config,
                                      Reconstruction* reconstruction) {
  PoseBlockBundleAdjuster bundle_adjuster(options, config);
  bundle_adjuster.SetUpProblem(reconstruction);
  if (bundle_adjuster.Problem().NumResiduals() == 0) {
    return false;
  }
  // COLMAP's choice of linear solver (by the number of images) and threads
  // (by the number of residuals).
  const ceres::Solver::Options solver_options =
      BundleAdjuster(options, config)
          .SetUpSolverOptions(bundle_adjuster.Problem(),
                              options.solver_options);
  const ceres::Solver::Summary summary =
      bundle_adjuster.Solve(solver_options, reconstruction);
  if (options.print_summary || VLOG_IS_ON(1)) {
    PrintSolverSummary(summary, "Bundle adjustment report");
  }
  return true;
}

}  // namespace colmap
