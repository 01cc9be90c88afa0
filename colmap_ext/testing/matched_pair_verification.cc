#include "colmap_ext/testing/matched_pair_verification.h"

#include "colmap/feature/utils.h"
#include "colmap/util/logging.h"
#include "colmap/util/threading.h"

#include <unordered_map>

namespace colmap {

MatchedPairVerificationStats VerifyMatchedPairs(
    const TwoViewGeometryOptions& options,
    const unsigned int seed,
    const int num_threads,
    Database* database) {
  THROW_CHECK(options.Check());
  THROW_CHECK_NOTNULL(database);

  std::unordered_map<camera_t, Camera> cameras;
  for (Camera& camera : database->ReadAllCameras()) {
    cameras.emplace(camera.camera_id, std::move(camera));
  }
  std::unordered_map<image_t, camera_t> image_cameras;
  std::unordered_map<image_t, std::vector<Eigen::Vector2d>> points;
  for (const Image& image : database->ReadAllImages()) {
    image_cameras.emplace(image.ImageId(), image.CameraId());
    points.emplace(
        image.ImageId(),
        FeatureKeypointsToPointsVector(database->ReadKeypoints(image.ImageId())));
  }

  std::vector<std::pair<image_pair_t, FeatureMatches>> pairs;
  for (auto& [pair_id, matches] : database->ReadAllMatches()) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    if (!database->ExistsTwoViewGeometry(image_id1, image_id2)) {
      pairs.emplace_back(pair_id, std::move(matches));
    }
  }

  std::vector<TwoViewGeometry> geometries(pairs.size());
  {
    ThreadPool thread_pool(GetEffectiveNumThreads(num_threads));
    for (size_t i = 0; i < pairs.size(); ++i) {
      thread_pool.AddTask([&, i]() {
        const auto& [pair_id, matches] = pairs[i];
        if (matches.size() < static_cast<size_t>(options.min_num_inliers)) {
          return;  // An empty geometry, as the verifier writes it.
        }
        const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
        TwoViewGeometryOptions pair_options = options;
        pair_options.ransac_options.random_seed =
            static_cast<int>((static_cast<uint64_t>(seed) * 2654435761u +
                              pair_id) %
                             2147483647u);
        TwoViewGeometry geometry =
            EstimateTwoViewGeometry(cameras.at(image_cameras.at(image_id1)),
                                    points.at(image_id1),
                                    cameras.at(image_cameras.at(image_id2)),
                                    points.at(image_id2),
                                    matches,
                                    pair_options);
        if (geometry.inlier_matches.size() >=
            static_cast<size_t>(options.min_num_inliers)) {
          geometries[i] = std::move(geometry);
        }
      });
    }
    thread_pool.Wait();
  }

  MatchedPairVerificationStats stats;
  DatabaseTransaction transaction(database);
  for (size_t i = 0; i < pairs.size(); ++i) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pairs[i].first);
    database->WriteTwoViewGeometry(image_id1, image_id2, geometries[i]);
    ++stats.num_matched_pairs;
    stats.num_matches += pairs[i].second.size();
    if (!geometries[i].inlier_matches.empty()) {
      ++stats.num_verified_pairs;
      stats.num_inlier_matches += geometries[i].inlier_matches.size();
    }
  }
  return stats;
}

}  // namespace colmap
