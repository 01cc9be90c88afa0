#include "colmap_ext/reconstruction/filtered_database_cache.h"

#include "colmap/feature/utils.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"

#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace colmap {
namespace {

// Reads all rigs and cameras into `cache`, and all frames and images; a
// database without rigs has one rig per camera, with the camera's id, and
// one without frames one frame per image, with the image's id.
void ReadRigsCamerasAndFrames(const Database& database,
                              DatabaseCache* cache,
                              std::unordered_map<frame_t, Frame>* frames,
                              std::vector<Image>* images) {
  const bool has_rigs = database.NumRigs() > 0;
  const bool has_frames = database.NumFrames() > 0;
  for (Rig& rig : database.ReadAllRigs()) {
    cache->AddRig(std::move(rig));
  }
  for (Camera& camera : database.ReadAllCameras()) {
    if (!has_rigs) {
      Rig rig;
      rig.SetRigId(camera.camera_id);
      rig.AddRefSensor(camera.SensorId());
      cache->AddRig(std::move(rig));
    }
    cache->AddCamera(std::move(camera));
  }

  for (Frame& frame : database.ReadAllFrames()) {
    frames->emplace(frame.FrameId(), std::move(frame));
  }
  *images = database.ReadAllImages();
  for (Image& image : *images) {
    if (has_frames) {
      THROW_CHECK(image.HasFrameId());
    } else {
      const frame_t frame_id = image.ImageId();
      Frame frame;
      frame.SetFrameId(frame_id);
      frame.SetRigId(image.CameraId());
      frame.AddDataId(image.DataId());
      image.SetFrameId(frame_id);
      frames->emplace(frame_id, std::move(frame));
    }
  }
}

// The pairs in use between the selected frames, by their inlier counts,
// then (for the watermark check) their configuration: the geometries read
// for that check are returned in `two_view_geometries`.
std::vector<image_pair_t> SelectImagePairs(
    const Database& database,
    const DatabaseCache::Options& options,
    const std::function<bool(image_t, image_t)>& use_image_pair,
    const std::unordered_set<frame_t>& selected_frame_ids,
    const std::unordered_map<image_t, frame_t>& frame_of_image,
    std::vector<TwoViewGeometry>* two_view_geometries) {
  std::vector<image_pair_t> pair_ids;
  for (const auto& [pair_id, num_inliers] :
       database.ReadTwoViewGeometryNumInliers()) {
    if (static_cast<size_t>(num_inliers) < options.min_num_matches) {
      continue;
    }
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    if (selected_frame_ids.count(frame_of_image.at(image_id1)) == 0 ||
        selected_frame_ids.count(frame_of_image.at(image_id2)) == 0 ||
        (use_image_pair && !use_image_pair(image_id1, image_id2))) {
      continue;
    }
    pair_ids.push_back(pair_id);
  }
  if (options.ignore_watermarks) {
    size_t num_kept = 0;
    for (const image_pair_t pair_id : pair_ids) {
      const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
      TwoViewGeometry two_view_geometry =
          database.ReadTwoViewGeometry(image_id1, image_id2);
      if (two_view_geometry.config != TwoViewGeometry::WATERMARK) {
        pair_ids[num_kept++] = pair_id;
        two_view_geometries->push_back(std::move(two_view_geometry));
      }
    }
    pair_ids.resize(num_kept);
  }
  return pair_ids;
}

}  // namespace

std::shared_ptr<DatabaseCache> CreateFilteredDatabaseCache(
    const Database& database,
    const DatabaseCache::Options& options,
    const std::function<bool(image_t, image_t)>& use_image_pair) {
  Timer timer;
  timer.Start();
  auto cache = std::make_shared<DatabaseCache>();

  std::unordered_map<frame_t, Frame> frames;
  std::vector<Image> images;
  ReadRigsCamerasAndFrames(database, cache.get(), &frames, &images);
  // The frames asked for: those holding one of `image_names` (a frame's
  // images stay together), or all.
  std::unordered_map<image_t, frame_t> frame_of_image;
  std::unordered_set<frame_t> selected_frame_ids;
  for (const Image& image : images) {
    frame_of_image.emplace(image.ImageId(), image.FrameId());
    if (options.image_names.empty() ||
        options.image_names.count(image.Name()) > 0) {
      selected_frame_ids.insert(image.FrameId());
    }
  }

  std::vector<TwoViewGeometry> two_view_geometries;
  const std::vector<image_pair_t> pair_ids =
      SelectImagePairs(database,
                       options,
                       use_image_pair,
                       selected_frame_ids,
                       frame_of_image,
                       &two_view_geometries);

  // The frames loaded: those a pair in use connects, or all asked for.
  std::unordered_set<frame_t> loaded_frame_ids;
  if (options.load_all_images) {
    loaded_frame_ids = selected_frame_ids;
  } else {
    for (const image_pair_t pair_id : pair_ids) {
      const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
      loaded_frame_ids.insert(frame_of_image.at(image_id1));
      loaded_frame_ids.insert(frame_of_image.at(image_id2));
    }
  }
  for (auto& [frame_id, frame] : frames) {
    if (loaded_frame_ids.count(frame_id) > 0) {
      cache->AddFrame(std::move(frame));
    }
  }
  frames.clear();

  // Their images with their keypoints (the correspondence graph learns of
  // each image as it is added).
  for (Image& image : images) {
    if (loaded_frame_ids.count(image.FrameId()) == 0) {
      continue;
    }
    image.SetPoints2D(FeatureKeypointsToPointsVector(
        database.ReadKeypoints(image.ImageId())));
    cache->AddImage(std::move(image));
  }
  const size_t num_images = images.size();
  images.clear();
  images.shrink_to_fit();

  // DatabaseCache converts pose priors to ENU (a private method) as it
  // loads or copies a cache: here as it copies a cache of the priors alone.
  DatabaseCache prior_cache;
  for (PosePrior& pose_prior : database.ReadAllPosePriors()) {
    prior_cache.AddPosePrior(std::move(pose_prior));
  }
  DatabaseCache::Options prior_options;
  prior_options.convert_pose_priors_to_enu = options.convert_pose_priors_to_enu;
  const std::shared_ptr<DatabaseCache> priors =
      DatabaseCache::CreateFromCache(prior_cache, prior_options);
  for (const PosePrior& pose_prior : priors->PosePriors()) {
    cache->AddPosePrior(pose_prior);
  }

  // Each pair's matches are read as they are added.
  CorrespondenceGraph& correspondence_graph = *cache->CorrespondenceGraph();
  for (size_t i = 0; i < pair_ids.size(); ++i) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_ids[i]);
    correspondence_graph.AddTwoViewGeometry(
        image_id1,
        image_id2,
        options.ignore_watermarks
            ? std::move(two_view_geometries[i])
            : database.ReadTwoViewGeometry(image_id1, image_id2));
  }
  correspondence_graph.Finalize();

  LOG(INFO) << StringPrintf("Loaded %d of %d images and %d image pairs (%.3fs)",
                            static_cast<int>(cache->NumImages()),
                            static_cast<int>(num_images),
                            static_cast<int>(pair_ids.size()),
                            timer.ElapsedSeconds());
  return cache;
}

}  // namespace colmap
