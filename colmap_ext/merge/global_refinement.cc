#include "colmap_ext/merge/global_refinement.h"

#include "colmap/scene/reconstruction_manager.h"
#include "colmap/sfm/incremental_mapper.h"
#include "colmap/util/logging.h"

namespace colmap {

GlobalMapperOptions MergedModelRefinementOptions(
    const IncrementalPipelineOptions& mapper_options,
    const double function_tolerance) {
  GlobalMapperOptions options;
  options.num_threads = mapper_options.num_threads;
  options.random_seed = mapper_options.random_seed;
  // GlobalMapper holds rigs all or none: a rig the user holds holds them all.
  options.refine_sensor_from_rig = mapper_options.ba_refine_sensor_from_rig &&
                                   mapper_options.constant_rigs.empty();
  BundleAdjustmentOptions& ba = options.bundle_adjustment;
  ba.refine_focal_length = mapper_options.ba_refine_focal_length;
  ba.refine_principal_point = mapper_options.ba_refine_principal_point;
  ba.refine_extra_params = mapper_options.ba_refine_extra_params;
  if (ba.ceres) {
    ba.ceres->solver_options.function_tolerance = function_tolerance;
    // On the CPU, as the incremental mapper's adjustments (the global
    // mapper's default asks for the GPU).
    ba.ceres->use_gpu = mapper_options.ba_use_gpu;
    ba.ceres->gpu_index = mapper_options.ba_gpu_index;
  }
  return options;
}

bool RefineMergedModel(const GlobalMapperOptions& options,
                       std::shared_ptr<const DatabaseCache> database_cache,
                       std::shared_ptr<Reconstruction> reconstruction) {
  GlobalMapper mapper(std::move(database_cache));
  mapper.BeginReconstruction(reconstruction);
  return mapper.IterativeRetriangulateAndRefine(
      options.Retriangulation(),
      options.BundleAdjustment(),
      options.max_normalized_reproj_error,
      options.min_tri_angle_deg);
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
