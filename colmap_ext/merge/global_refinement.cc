#include "colmap_ext/merge/global_refinement.h"

#include "colmap/estimators/bundle_adjustment.h"
#include "colmap/scene/reconstruction_manager.h"
#include "colmap/sfm/incremental_mapper.h"
#include "colmap/sfm/observation_manager.h"
#include "colmap/util/logging.h"

namespace colmap {

GlobalMapperOptions MergedModelRefinementOptions(
    const IncrementalPipelineOptions& mapper_options) {
  GlobalMapperOptions options;
  options.num_threads = mapper_options.num_threads;
  options.random_seed = mapper_options.random_seed;
  options.refine_sensor_from_rig = mapper_options.ba_refine_sensor_from_rig;
  BundleAdjustmentOptions& ba = options.bundle_adjustment;
  ba.refine_focal_length = mapper_options.ba_refine_focal_length;
  ba.refine_principal_point = mapper_options.ba_refine_principal_point;
  ba.refine_extra_params = mapper_options.ba_refine_extra_params;
  if (ba.ceres) {
    ba.ceres->solver_options.function_tolerance =
        mapper_options.ba_global_function_tolerance;
    // On the CPU, as the incremental mapper's adjustments (the global
    // mapper's default asks for the GPU).
    ba.ceres->use_gpu = mapper_options.ba_use_gpu;
    ba.ceres->gpu_index = mapper_options.ba_gpu_index;
  }
  return options;
}

// GlobalMapper::IterativeRetriangulateAndRefine's steps with one round before
// the final adjustment (not reused: completing tracks at 15 px and filtering
// at 4 px, its rounds rarely stop before the fifth, each a global adjustment).
bool RefineMergedModel(const IncrementalPipelineOptions& incremental_options,
                       std::shared_ptr<const DatabaseCache> database_cache,
                       std::shared_ptr<Reconstruction> reconstruction) {
  const GlobalMapperOptions options =
      MergedModelRefinementOptions(incremental_options);
  const IncrementalMapper::Options mapper_options =
      incremental_options.Mapper();
  const IncrementalTriangulator::Options triangulation =
      options.Retriangulation();
  const BundleAdjustmentOptions ba_options = options.BundleAdjustment();
  reconstruction->DeleteAllPoints2DAndPoints3D();
  IncrementalMapper mapper(std::move(database_cache));
  mapper.BeginReconstruction(reconstruction);
  for (const image_t image_id : reconstruction->RegImageIds()) {
    mapper.TriangulateImage(triangulation, image_id);
  }
  BundleAdjustmentOptions round_ba_options = ba_options;
  if (round_ba_options.ceres) {
    round_ba_options.ceres->solver_options.max_num_iterations = 50;
    round_ba_options.ceres->solver_options.max_linear_solver_iterations = 100;
  }
  mapper.IterativeGlobalRefinement(/*max_num_refinements=*/1,
                                   /*max_refinement_change=*/0.0005,
                                   mapper_options,
                                   round_ba_options,
                                   triangulation,
                                   /*normalize_reconstruction=*/true);
  // The filters work on the mapper's own bookkeeping of observations.
  ObservationManager& observation_manager = mapper.ObservationManager();
  observation_manager.FilterPoints3DWithLargeReprojectionError(
      options.max_normalized_reproj_error,
      reconstruction->Point3DIds(),
      ReprojectionErrorType::NORMALIZED);
  // The final adjustment as the incremental mapper's own (its gauge and the
  // cameras and rigs the user holds).
  const bool adjusted = reconstruction->NumPoints3D() > 0 &&
                        mapper.AdjustGlobalBundle(mapper_options, ba_options);
  if (adjusted) {
    reconstruction->Normalize();
    // The points as the incremental mapper leaves its own (--Mapper.filter_*).
    observation_manager.FilterAllPoints3D(
        mapper_options.filter_max_reproj_error,
        mapper_options.filter_min_tri_angle);
  }
  mapper.EndReconstruction(/*discard=*/false);
  return adjusted;
}

int RegisterRemainingImages(
    std::shared_ptr<IncrementalPipelineOptions> mapper_options,
    std::shared_ptr<DatabaseCache> database_cache,
    std::shared_ptr<Reconstruction> reconstruction) {
  const int num_reg_images = static_cast<int>(reconstruction->NumRegImages());
  // The pipeline keeps a copy of the cache: the mapper works on that one.
  IncrementalPipeline pipeline(mapper_options,
                               std::move(database_cache),
                               std::make_shared<ReconstructionManager>());
  IncrementalMapper mapper(pipeline.DatabaseCache());
  const IncrementalPipeline::Status status = pipeline.ReconstructSubModel(
      mapper, mapper_options->Mapper(), reconstruction);
  mapper.EndReconstruction(/*discard=*/false);
  if (status != IncrementalPipeline::Status::SUCCESS &&
      status != IncrementalPipeline::Status::INTERRUPTED) {
    LOG(WARNING) << "The incremental mapper could not continue the merged "
                    "model: its remaining images stay unregistered.";
  }
  return static_cast<int>(reconstruction->NumRegImages()) - num_reg_images;
}

}  // namespace colmap
