// One community reconstructed by COLMAP's incremental mapper.
//
// CSfM (Cui et al., ICIP 2017), section 2.2: COLMAP's IncrementalPipeline on
// the community's own and borrowed images, communities (in threads or
// processes) sharing one database. Only the community's pairs are loaded
// (filtered_database_cache.h), under `database_mutex`, retried where a load
// found nothing (a cluster's array jobs start together; database_retry.h).
// The thread's random number generator is seeded anew (the same model
// whichever worker runs it), and no further model is started that would be
// discarded after minutes of failed initializations (RoomForAnotherModel).
// The largest model is the community's; the others are kept beside it,
// largest first, for the merge (community_merger.h).

#pragma once

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/scene/reconstruction_manager.h"

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace colmap {

struct CommunityReconstruction {
  // The largest model (nullptr if the mapper made none).
  std::shared_ptr<Reconstruction> model;
  // The mapper's other models, largest first.
  std::vector<std::shared_ptr<Reconstruction>> other_models;
  // Models the mapper made.
  int num_models = 0;
};

// Whether at least `min_model_size` of `num_images` images are registered in
// none of `models`: the images a further model of the incremental pipeline
// starts from, which it keeps only from that size on (a model started from
// fewer could reach it only with images another model holds already).
bool RoomForAnotherModel(const ReconstructionManager& models,
                         size_t num_images,
                         int min_model_size);

// `options.image_names` holds the community's images; `options` are the
// user's --Mapper.* settings, as `colmap mapper` runs them.
CommunityReconstruction ReconstructCommunityModels(
    std::shared_ptr<const IncrementalPipelineOptions> options,
    const std::string& image_path,
    const std::string& database_path,
    std::mutex* database_mutex);

}  // namespace colmap
