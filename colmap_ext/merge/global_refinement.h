// Refinement of a merged model over all its images, and registration of the
// images that no community placed.
//
// As GLOMAP ends (Pan et al., "Global Structure-from-Motion Revisited",
// ECCV 2024; COLMAP 4.1.1's GlobalMapper), the merged model is triangulated
// anew over the whole correspondence graph, so that tracks cross the
// communities' borders, and adjusted under a robust (Huber) loss:
//     min  sum_ij rho(|| pi(P_i, X_j) - x_ij ||^2).
// The images left are then registered as COLMAP's incremental mapper
// continues a model (IncrementalPipeline::ReconstructSubModel).

#pragma once

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/database_cache.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/sfm/global_mapper.h"
#include "colmap/sfm/incremental_mapper.h"

#include <memory>

namespace colmap {

// GlobalMapper's retriangulation and adjustment defaults; the intrinsics and
// rigs refined, the threads, the seed and the adjustments' tolerance
// (ba_global_function_tolerance) follow --Mapper.*.
GlobalMapperOptions MergedModelRefinementOptions(
    const IncrementalPipelineOptions& mapper_options);

// Refines `reconstruction` (its registered images, on `database_cache`'s
// correspondences): every point triangulated anew, one round of track
// completion, adjustment and filtering, and a final adjustment, under the
// user's filters, constant cameras and rigs and global adjustment tolerance
// (`incremental_options`, --Mapper.*). Returns false where the final
// adjustment failed.
bool RefineMergedModel(const IncrementalPipelineOptions& incremental_options,
                       std::shared_ptr<const DatabaseCache> database_cache,
                       std::shared_ptr<Reconstruction> reconstruction);

// Registers the images of `database_cache` that `reconstruction` has not
// registered, as the incremental mapper continues a model, and refines the
// result; the unregistered images are removed from it. Returns how many
// more images it holds (fewer where the refinement filtered some).
int RegisterRemainingImages(
    std::shared_ptr<IncrementalPipelineOptions> mapper_options,
    std::shared_ptr<DatabaseCache> database_cache,
    std::shared_ptr<Reconstruction> reconstruction);

}  // namespace colmap
