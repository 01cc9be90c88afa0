#include "colmap_ext/reconstruction/filtered_database_cache.h"

#include "colmap/geometry/gps.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"

#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace colmap {
namespace {

// Ellipsoidal (WGS84) pose priors as Cartesian ENU coordinates around the
// first one, where all priors are WGS84 ones; other priors are left as they
// are. Priors in more than one coordinate system are an error.
void ConvertPosePriorsToENU(std::vector<PosePrior>* pose_priors) {
  std::set<PosePrior::CoordinateSystem> coordinate_systems;
  std::vector<Eigen::Vector3d> lat_lon_alt;
  lat_lon_alt.reserve(pose_priors->size());
  for (const PosePrior& pose_prior : *pose_priors) {
    coordinate_systems.insert(pose_prior.coordinate_system);
    lat_lon_alt.push_back(pose_prior.position);
  }
  THROW_CHECK_LE(coordinate_systems.size(), 1)
      << "Inconsistent coordinate systems defined in pose priors";
  if (lat_lon_alt.empty() ||
      *coordinate_systems.begin() != PosePrior::CoordinateSystem::WGS84) {
    return;
  }
  const Eigen::Vector3d& reference = lat_lon_alt.front();
  const std::vector<Eigen::Vector3d> enu =
      GPSTransform(GPSTransform::Ellipsoid::WGS84)
          .EllipsoidToENU(
              lat_lon_alt, reference(0), reference(1), reference(2));
  for (size_t i = 0; i < pose_priors->size(); ++i) {
    (*pose_priors)[i].position = enu[i];
    (*pose_priors)[i].coordinate_system =
        PosePrior::CoordinateSystem::CARTESIAN;
  }
}

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

  if (has_frames) {
    for (Frame& frame : database.ReadAllFrames()) {
      const frame_t frame_id = frame.FrameId();
      frames->emplace(frame_id, std::move(frame));
    }
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
  std::unordered_map<image_t, frame_t> frame_of_image;
  frame_of_image.reserve(images.size());
  for (const Image& image : images) {
    frame_of_image.emplace(image.ImageId(), image.FrameId());
  }

  // The frames asked for: those holding one of `image_names` (a frame's
  // images stay together), or all.
  std::unordered_set<frame_t> selected_frame_ids;
  for (const Image& image : images) {
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
    const FeatureKeypoints keypoints = database.ReadKeypoints(image.ImageId());
    std::vector<Eigen::Vector2d> points2D;
    points2D.reserve(keypoints.size());
    for (const FeatureKeypoint& keypoint : keypoints) {
      points2D.emplace_back(keypoint.x, keypoint.y);
    }
    image.SetPoints2D(points2D);
    cache->AddImage(std::move(image));
  }
  const size_t num_images = images.size();
  images.clear();
  images.shrink_to_fit();

  std::vector<PosePrior> pose_priors = database.ReadAllPosePriors();
  if (options.convert_pose_priors_to_enu) {
    ConvertPosePriorsToENU(&pose_priors);
  }
  for (PosePrior& pose_prior : pose_priors) {
    cache->AddPosePrior(std::move(pose_prior));
  }

  // Each pair's matches are read as they are added.
  CorrespondenceGraph& correspondence_graph = *cache->CorrespondenceGraph();
  for (size_t i = 0; i < pair_ids.size(); ++i) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_ids[i]);
    if (options.ignore_watermarks) {
      correspondence_graph.AddTwoViewGeometry(
          image_id1, image_id2, std::move(two_view_geometries[i]));
    } else {
      correspondence_graph.AddTwoViewGeometry(
          image_id1,
          image_id2,
          database.ReadTwoViewGeometry(image_id1, image_id2));
    }
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
