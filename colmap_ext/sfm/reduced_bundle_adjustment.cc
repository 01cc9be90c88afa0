#include "colmap_ext/sfm/reduced_bundle_adjustment.h"

#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"

#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace colmap {
namespace {

// Orders tracks for selection: longer first (up to the long track length),
// then smaller reprojection error (unknown errors last), then id.
struct TrackRank {
  int length;
  double error;
  point3D_t point3D_id;

  bool operator<(const TrackRank& other) const {
    if (length != other.length) return length > other.length;
    if (error != other.error) return error < other.error;
    return point3D_id < other.point3D_id;
  }
};

TrackRank RankOf(const TrackSelectionOptions& options,
                 const point3D_t point3D_id,
                 const Point3D& point3D) {
  return {
      std::min(static_cast<int>(point3D.track.Length()),
               options.long_track_length),
      point3D.error < 0 ? std::numeric_limits<double>::max() : point3D.error,
      point3D_id};
}

// The configuration of COLMAP's mapper's global adjustment: every image of
// the registered frames, the gauge held by two frames, the intrinsics of
// `constant_cameras` and the sensor poses of `constant_rigs` held.
BundleAdjustmentConfig MappersConfig(
    const Reconstruction& reconstruction,
    const std::unordered_set<camera_t>& constant_cameras,
    const std::unordered_set<rig_t>& constant_rigs) {
  BundleAdjustmentConfig config;
  for (const frame_t frame_id : reconstruction.RegFrameIds()) {
    for (const data_t& data_id : reconstruction.Frame(frame_id).ImageIds()) {
      config.AddImage(data_id.id);
      const camera_t camera_id = reconstruction.Image(data_id.id).CameraId();
      if (constant_cameras.count(camera_id) > 0) {
        config.SetConstantCamIntrinsics(camera_id);
      }
    }
  }
  for (const rig_t rig_id : constant_rigs) {
    if (reconstruction.ExistsRig(rig_id)) {
      for (const auto& [sensor_id, _] :
           reconstruction.Rig(rig_id).NonRefSensors()) {
        config.SetConstantSensorFromRigPose(sensor_id);
      }
    }
  }
  config.FixGauge(BundleAdjustmentGauge::TWO_CAMS_FROM_WORLD);
  return config;
}

// Solves the bundle adjustment of `config` with COLMAP's Ceres adjuster and
// `solver_options` as they are: neither the linear solver nor the number of
// threads is chosen by the size of the problem.
ceres::Solver::Summary SolveOnCeres(const BundleAdjustmentOptions& ba_options,
                                    ceres::Solver::Options solver_options,
                                    const BundleAdjustmentConfig& config,
                                    Reconstruction* reconstruction) {
  BundleAdjustmentOptions options = ba_options;
  options.backend = BundleAdjustmentBackend::CERES;
  THROW_CHECK_NOTNULL(options.ceres);
  options.ceres->solver_options = std::move(solver_options);
  options.ceres->auto_select_solver_type = false;
  options.ceres->min_num_residuals_for_cpu_multi_threading = 0;
  const std::shared_ptr<BundleAdjustmentSummary> summary =
      CreateDefaultBundleAdjuster(options, config, *reconstruction)->Solve();
  if (const auto ceres_summary =
          std::dynamic_pointer_cast<CeresBundleAdjustmentSummary>(summary)) {
    return ceres_summary->ceres_summary;
  }
  ceres::Solver::Summary no_solve;
  no_solve.message = "no observations";
  return no_solve;
}

}  // namespace

bool TrackSelectionOptions::Check() const {
  CHECK_OPTION_GT(grid_size, 0);
  CHECK_OPTION_GE(long_track_length, 2);
  CHECK_OPTION_GE(min_tracks_per_image, 0);
  return true;
}

std::unordered_set<point3D_t> SelectBundleTracks(
    const TrackSelectionOptions& options,
    const Reconstruction& reconstruction) {
  THROW_CHECK(options.Check());
  std::unordered_set<point3D_t> selected;
  std::vector<TrackRank> ranks;
  for (const image_t image_id : reconstruction.RegImageIds()) {
    const Image& image = reconstruction.Image(image_id);
    const Camera& camera = reconstruction.Camera(image.CameraId());
    const double cell_width =
        std::max<double>(camera.width, 1) / options.grid_size;
    const double cell_height =
        std::max<double>(camera.height, 1) / options.grid_size;
    auto cell_index = [&options](const double coordinate,
                                 const double cell_size) {
      return std::max(0,
                      std::min(static_cast<int>(coordinate / cell_size),
                               options.grid_size - 1));
    };
    // Per cell: the best track observed there, unless a track selected
    // for an earlier image already is.
    std::unordered_map<int, TrackRank> best_in_cell;
    std::unordered_set<int> covered_cells;
    int num_selected = 0;
    ranks.clear();
    for (const Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D()) {
        continue;
      }
      const int cell =
          cell_index(point2D.xy.y(), cell_height) * options.grid_size +
          cell_index(point2D.xy.x(), cell_width);
      if (selected.count(point2D.point3D_id)) {
        covered_cells.insert(cell);
        ++num_selected;
        continue;
      }
      const TrackRank rank = RankOf(options,
                                    point2D.point3D_id,
                                    reconstruction.Point3D(point2D.point3D_id));
      ranks.push_back(rank);
      const auto inserted = best_in_cell.emplace(cell, rank);
      if (!inserted.second && rank < inserted.first->second) {
        inserted.first->second = rank;
      }
    }
    for (const auto& cell : best_in_cell) {
      if (covered_cells.count(cell.first) == 0) {
        num_selected += selected.insert(cell.second.point3D_id).second;
      }
    }
    // Tracks crowded into few cells: the image's next best ones.
    if (num_selected < options.min_tracks_per_image) {
      std::sort(ranks.begin(), ranks.end());
      for (const TrackRank& rank : ranks) {
        if (num_selected >= options.min_tracks_per_image) {
          break;
        }
        num_selected += selected.insert(rank.point3D_id).second;
      }
    }
  }
  return selected;
}

std::string SolverSummaryToString(const ceres::Solver::Options& options,
                                  const ceres::Solver::Summary& summary,
                                  const double seconds) {
  std::string stopped;
  switch (summary.termination_type) {
    case ceres::CONVERGENCE:
      stopped = "converged";
      break;
    case ceres::NO_CONVERGENCE:
      stopped = "iteration limit";
      break;
    default:
      stopped = summary.message;
  }
  return StringPrintf(
      "%d iterations, cost %.4g -> %.4g, %.1fs (%s, %s)",
      static_cast<int>(summary.iterations.size()),
      summary.initial_cost,
      summary.final_cost,
      seconds,
      ceres::LinearSolverTypeToString(options.linear_solver_type),
      stopped.c_str());
}

ceres::Solver::Summary AdjustAllObservations(
    const BundleAdjustmentOptions& ba_options,
    ceres::Solver::Options solver_options,
    Reconstruction* reconstruction,
    const std::unordered_set<camera_t>& constant_cameras,
    const std::unordered_set<rig_t>& constant_rigs) {
  THROW_CHECK_NOTNULL(reconstruction);
  if (reconstruction->NumRegImages() < 2) {
    ceres::Solver::Summary summary;
    summary.message = "fewer than two registered images";
    return summary;
  }
  return SolveOnCeres(
      ba_options,
      std::move(solver_options),
      MappersConfig(*reconstruction, constant_cameras, constant_rigs),
      reconstruction);
}

bool AdjustCamerasOnTracks(const BundleAdjustmentOptions& ba_options,
                           ceres::Solver::Options solver_options,
                           const std::unordered_set<point3D_t>& point3D_ids,
                           Reconstruction* reconstruction,
                           const std::unordered_set<camera_t>& constant_cameras,
                           const std::unordered_set<rig_t>& constant_rigs) {
  THROW_CHECK_NOTNULL(reconstruction);
  if (reconstruction->NumRegImages() < 2 || point3D_ids.empty()) {
    return false;
  }
  Timer timer;
  timer.Start();
  BundleAdjustmentConfig config =
      MappersConfig(*reconstruction, constant_cameras, constant_rigs);
  for (const auto& [point3D_id, _] : reconstruction->Points3D()) {
    if (point3D_ids.count(point3D_id) == 0) {
      config.IgnorePoint(point3D_id);
    }
  }
  const ceres::Solver::Summary summary =
      SolveOnCeres(ba_options, solver_options, config, reconstruction);
  std::unordered_set<image_t> image_ids;
  for (const point3D_t point3D_id : point3D_ids) {
    for (const TrackElement& track_el :
         reconstruction->Point3D(point3D_id).track.Elements()) {
      image_ids.insert(track_el.image_id);
    }
  }
  LOG(INFO) << StringPrintf(
      "Bundle adjustment of %d images on %d of %d points, %d residuals: %s",
      static_cast<int>(image_ids.size()),
      static_cast<int>(point3D_ids.size()),
      static_cast<int>(reconstruction->NumPoints3D()),
      summary.num_residuals,
      SolverSummaryToString(solver_options, summary, timer.ElapsedSeconds())
          .c_str());
  return summary.IsSolutionUsable();
}

size_t RefinePointsWithFixedCameras(
    const BundleAdjustmentOptions& ba_options,
    const std::unordered_set<point3D_t>& excluded_point3D_ids,
    const int max_points_per_problem,
    Reconstruction* reconstruction) {
  THROW_CHECK_NOTNULL(reconstruction);
  THROW_CHECK_GT(max_points_per_problem, 0);
  BundleAdjustmentOptions options = ba_options;
  options.print_summary = false;
  if (options.ceres) {
    options.ceres->loss_function_type =
        CeresBundleAdjustmentOptions::LossFunctionType::TRIVIAL;
    options.ceres->solver_options.max_num_iterations =
        std::min(options.ceres->solver_options.max_num_iterations, 10);
  }

  std::vector<point3D_t> point3D_ids;
  point3D_ids.reserve(reconstruction->NumPoints3D());
  for (const auto& point3D : reconstruction->Points3D()) {
    if (excluded_point3D_ids.count(point3D.first) == 0) {
      point3D_ids.push_back(point3D.first);
    }
  }
  std::vector<Eigen::Vector3d> initial_xyz;
  for (size_t begin = 0; begin < point3D_ids.size();
       begin += max_points_per_problem) {
    const size_t end =
        std::min(point3D_ids.size(),
                 begin + static_cast<size_t>(max_points_per_problem));
    BundleAdjustmentConfig config;
    initial_xyz.clear();
    for (size_t k = begin; k < end; ++k) {
      config.AddVariablePoint(point3D_ids[k]);
      initial_xyz.push_back(reconstruction->Point3D(point3D_ids[k]).xyz);
    }
    // Without images in the configuration, the adjuster holds every camera
    // (pose and intrinsics) constant and adjusts the points alone.
    CreateDefaultBundleAdjuster(options, config, *reconstruction)->Solve();
    // A point of nearly parallel rays can run off along them, even behind
    // its cameras: it keeps its place (filtering judges it).
    for (size_t k = begin; k < end; ++k) {
      Point3D& point3D = reconstruction->Point3D(point3D_ids[k]);
      for (const TrackElement& track_el : point3D.track.Elements()) {
        const Rigid3d cam_from_world =
            reconstruction->Image(track_el.image_id).CamFromWorld();
        if ((cam_from_world * point3D.xyz).z() <
            std::numeric_limits<double>::epsilon()) {
          point3D.xyz = initial_xyz[k - begin];
          break;
        }
      }
    }
  }
  return point3D_ids.size();
}

}  // namespace colmap
