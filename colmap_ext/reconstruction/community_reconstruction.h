// One community reconstructed by COLMAP's incremental mapper.
//
// CSfM (Cui et al., ICIP 2017), section 2.2: each community is reconstructed
// on its own by incremental SfM. This is COLMAP's IncrementalPipeline on the
// community's images (its own and those it borrows from its neighbours),
// with three differences that let several communities, in threads or in
// processes, share one database:
//   - the community's images are loaded with CreateFilteredDatabaseCache
//     (filtered_database_cache.h), which reads the two-view geometries of
//     the community's image pairs only, not the whole database's;
//   - the database is loaded under `database_mutex` (shared by the threads
//     of one process: COLMAP's Database sets no SQLite busy timeout, so two
//     connections opening it together fail with "database is locked" unless
//     the process waits on locks, database_retry.h), and a load that found
//     nothing is retried a few times (for other processes, e.g. the jobs of
//     a cluster's job array);
//   - the random number generator of the reconstructing thread is seeded
//     anew, so that a community gives the same model whichever worker,
//     thread or process reconstructs it (with one thread per community).
// The pipeline starts new models until at most one image is left
// unregistered. A community's images that its first model leaves out are
// mostly those whose matches lie in other communities: where fewer are left
// than a model needs to be kept (Mapper.min_model_size), every model started
// from them is discarded, after failed initializations and registrations in
// each of the pipeline's relaxation rounds (long work for nothing), so the
// pipeline stops there (RoomForAnotherModel).
// Where the mapper makes several models, the largest is the community's and
// the others are kept beside it, largest first: the merge lets those that
// hold enough of the community's images take part as communities of their
// own (community_mapper.h), instead of registering their images anew.

#pragma once

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/scene/reconstruction_manager.h"

#include <memory>
#include <mutex>
#include <string>
#include <unordered_set>
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
