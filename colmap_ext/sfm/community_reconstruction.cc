#include "colmap_ext/sfm/community_reconstruction.h"

#include "colmap_ext/sfm/pose_block_bundle_adjustment.h"
#include "colmap_ext/util/database_retry.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/math/random.h"
#include "colmap/scene/database.h"
#include "colmap/scene/reconstruction_manager.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <unordered_map>

namespace colmap {

CommunityReconstruction ReconstructCommunityModels(
    std::shared_ptr<const IncrementalMapperOptions> options,
    const std::string& image_path,
    const std::string& database_path,
    std::mutex* database_mutex) {
  THROW_CHECK_NOTNULL(database_mutex);
  SetPRNGSeed(kDefaultPRNGSeed);
  auto reconstruction_manager = std::make_shared<ReconstructionManager>();
  IncrementalMapperController mapper(
      options, image_path, database_path, reconstruction_manager);

  // Another process may hold the database for a moment (database_retry.h).
  if (!RetryDatabaseAccess(database_path, [&]() {
        std::lock_guard<std::mutex> lock(*database_mutex);
        return mapper.LoadDatabase();
      })) {
    LOG(WARNING) << "No images with matches could be loaded from "
                 << database_path;
    return CommunityReconstruction();
  }
  // The correspondence graph's construction freed a vector per keypoint.
  ReleaseFreedMemory();

  // As IncrementalMapperController::Run: where no initial pair is found,
  // relax the constraints. The global adjustments solve COLMAP's problem
  // with a parameter block per pose (pose_block_bundle_adjustment.h).
  IncrementalMapper::Options init_options = options->Mapper();
  init_options.global_bundle_adjuster = AdjustGlobalBundleWithPoseBlocks;
  mapper.Reconstruct(init_options);
  constexpr int kNumInitRelaxations = 2;
  for (int i = 0;
       i < kNumInitRelaxations && reconstruction_manager->Size() == 0;
       ++i) {
    init_options.init_min_num_inliers /= 2;
    mapper.Reconstruct(init_options);
    if (reconstruction_manager->Size() > 0) {
      break;
    }
    init_options.init_min_tri_angle /= 2;
    mapper.Reconstruct(init_options);
  }

  CommunityReconstruction result;
  result.num_models = static_cast<int>(reconstruction_manager->Size());
  std::vector<std::shared_ptr<Reconstruction>> models;
  for (size_t i = 0; i < reconstruction_manager->Size(); ++i) {
    models.push_back(reconstruction_manager->Get(i));
  }
  // Largest first; of equal ones, the one the mapper made first.
  std::stable_sort(models.begin(),
                   models.end(),
                   [](const std::shared_ptr<Reconstruction>& a,
                      const std::shared_ptr<Reconstruction>& b) {
                     return a->NumRegImages() > b->NumRegImages();
                   });
  if (!models.empty()) {
    result.model = models[0];
    result.other_models.assign(models.begin() + 1, models.end());
  }
  return result;
}

double OwnCameraFraction(const std::string& database_path,
                         const std::unordered_set<std::string>& image_names,
                         std::mutex* database_mutex) {
  std::vector<Image> images;
  RetryDatabaseAccessOrThrow(database_path, [&]() {
    std::lock_guard<std::mutex> lock(*database_mutex);
    images = Database(database_path).ReadAllImages();
  });
  std::unordered_map<camera_t, int> num_images_of_camera;
  for (const Image& image : images) {
    ++num_images_of_camera[image.CameraId()];
  }
  int num_own = 0;
  int num_found = 0;
  for (const Image& image : images) {
    if (image_names.count(image.Name()) > 0) {
      ++num_found;
      num_own += num_images_of_camera.at(image.CameraId()) == 1 ? 1 : 0;
    }
  }
  return num_found == 0 ? 0.0 : static_cast<double>(num_own) / num_found;
}

}  // namespace colmap
