#include "colmap_ext/reconstruction/community_reconstruction.h"

#include "colmap_ext/reconstruction/filtered_database_cache.h"
#include "colmap_ext/util/process_memory.h"
#include "colmap_ext/workflow/database_retry.h"

#include "colmap/math/random.h"
#include "colmap/scene/database.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <unordered_set>
#include <utility>

namespace colmap {

bool RoomForAnotherModel(const ReconstructionManager& models,
                         const size_t num_images,
                         const int min_model_size) {
  std::unordered_set<image_t> registered;
  for (size_t i = 0; i < models.Size(); ++i) {
    const std::vector<image_t> image_ids = models.Get(i)->RegImageIds();
    registered.insert(image_ids.begin(), image_ids.end());
  }
  THROW_CHECK_LE(registered.size(), num_images);
  return num_images - registered.size() >=
         static_cast<size_t>(std::max(min_model_size, 0));
}

CommunityReconstruction ReconstructCommunityModels(
    std::shared_ptr<const IncrementalPipelineOptions> options,
    const std::string& image_path,
    const std::string& database_path,
    std::mutex* database_mutex) {
  THROW_CHECK_NOTNULL(options);
  THROW_CHECK_NOTNULL(database_mutex);
  SetPRNGSeed(kDefaultPRNGSeed);

  // The community's images and the image pairs among them, selected as the
  // pipeline selects them.
  DatabaseCache::Options cache_options;
  cache_options.min_num_matches = static_cast<size_t>(options->min_num_matches);
  cache_options.ignore_watermarks = options->ignore_watermarks;
  cache_options.image_names = {options->image_names.begin(),
                               options->image_names.end()};
  cache_options.load_all_images = options->load_all_images;
  cache_options.convert_pose_priors_to_enu = options->use_prior_position;
  std::shared_ptr<DatabaseCache> database_cache;
  // Another process may hold the database for a moment (database_retry.h).
  if (!RetryDatabaseAccess(database_path, [&]() {
        std::lock_guard<std::mutex> lock(*database_mutex);
        database_cache = CreateFilteredDatabaseCache(
            *Database::Open(database_path), cache_options);
        return database_cache->NumImages() > 0;
      })) {
    LOG(WARNING) << "No images with matches could be loaded from "
                 << database_path;
    return CommunityReconstruction();
  }
  // The correspondence graph's construction freed a vector per keypoint.
  ReleaseFreedMemory();

  // COLMAP's incremental pipeline as `colmap mapper` runs it. It keeps a copy
  // of the cache (of the same images); this one is released once it is made.
  auto pipeline_options =
      std::make_shared<IncrementalPipelineOptions>(*options);
  pipeline_options->image_path = image_path;
  auto reconstruction_manager = std::make_shared<ReconstructionManager>();
  const size_t num_images = database_cache->NumImages();
  IncrementalPipeline pipeline(
      pipeline_options, std::move(database_cache), reconstruction_manager);
  ReleaseFreedMemory();
  // The pipeline starts models until at most one image is left unregistered;
  // here it stops where no further model could be kept (see the header).
  bool no_room_for_a_model = false;
  pipeline.AddCallback(IncrementalPipeline::LAST_IMAGE_REG_CALLBACK, [&]() {
    no_room_for_a_model = !RoomForAnotherModel(
        *reconstruction_manager, num_images, pipeline_options->min_model_size);
  });
  pipeline.SetCheckIfStoppedFunc([&]() { return no_room_for_a_model; });
  pipeline.Run();

  CommunityReconstruction result;
  result.num_models = static_cast<int>(reconstruction_manager->Size());
  std::vector<std::shared_ptr<Reconstruction>> models;
  for (size_t i = 0; i < reconstruction_manager->Size(); ++i) {
    models.push_back(reconstruction_manager->Get(i));
  }
  // Largest first; of equal ones, the one the mapper made first.
  std::stable_sort(
      models.begin(), models.end(), [](const auto& a, const auto& b) {
        return a->NumRegImages() > b->NumRegImages();
      });
  if (!models.empty()) {
    result.model = models[0];
    result.other_models.assign(models.begin() + 1, models.end());
  }
  return result;
}

}  // namespace colmap
