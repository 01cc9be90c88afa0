#include "colmap_ext/merge/model_join.h"

#include "colmap/util/logging.h"

namespace colmap {
namespace {

// Which reconstruction each registered frame comes from: the first that
// registered it and owns one of its images (a frame's images share one
// pose and stay together).
class FrameSources {
 public:
  FrameSources(
      const std::vector<Reconstruction*>& reconstructions,
      const std::vector<std::unordered_set<image_t>>& owned_image_ids) {
    std::unordered_set<image_t> owned;
    for (size_t r = 0; r < reconstructions.size(); ++r) {
      const Reconstruction& reconstruction = *reconstructions[r];
      for (const frame_t frame_id : reconstruction.RegFrameIds()) {
        for (const data_t& data_id :
             reconstruction.Frame(frame_id).ImageIds()) {
          if (owned_image_ids[r].count(data_id.id) == 0) {
            continue;
          }
          THROW_CHECK(owned.insert(data_id.id).second)
              << "Image " << reconstruction.Image(data_id.id).Name()
              << " is owned by two reconstructions.";
          source_.emplace(frame_id, r);  // An earlier source stays.
        }
      }
    }
  }

  // Whether reconstruction r gives the frame.
  bool Takes(const size_t r, const frame_t frame_id) const {
    const auto it = source_.find(frame_id);
    return it != source_.end() && it->second == r;
  }

 private:
  std::unordered_map<frame_t, size_t> source_;
};

// The merged rig's sensor poses: every community's mapper refined the rig
// on its own frames, one on few of them perhaps, so each is the average of
// all estimates (in the world frame), weighted by their frames.
void AverageSensorPoses(
    const std::vector<Reconstruction*>& reconstructions,
    const std::vector<std::unordered_map<rig_t, size_t>>& num_frames_of_rig,
    const rig_t rig_id,
    Rig* merged_rig) {
  for (auto& [sensor_id, sensor_from_rig] : merged_rig->NonRefSensors()) {
    if (!sensor_from_rig) {
      continue;
    }
    const Eigen::Vector4d reference = sensor_from_rig->rotation().coeffs();
    Eigen::Vector4d rotation_sum = Eigen::Vector4d::Zero();
    Eigen::Vector3d translation_sum = Eigen::Vector3d::Zero();
    double weight_sum = 0;
    for (size_t r = 0; r < reconstructions.size(); ++r) {
      const auto it = num_frames_of_rig[r].find(rig_id);
      if (it == num_frames_of_rig[r].end() ||
          !reconstructions[r]->Rig(rig_id).HasSensorFromRig(sensor_id)) {
        continue;
      }
      const Rigid3d& pose =
          reconstructions[r]->Rig(rig_id).SensorFromRig(sensor_id);
      Eigen::Vector4d rotation = pose.rotation().coeffs();
      if (rotation.dot(reference) < 0) {
        rotation = -rotation;
      }
      const double weight = static_cast<double>(it->second);
      rotation_sum += weight * rotation;
      translation_sum += weight * pose.translation();
      weight_sum += weight;
    }
    if (weight_sum > 0) {
      *sensor_from_rig = Rigid3d(Eigen::Quaterniond(rotation_sum.normalized()),
                                 translation_sum / weight_sum);
    }
  }
}

// Cameras and rigs: those of the reconstruction owning the most images
// with them (frames of them); a rig's other cameras come with it.
void JoinCamerasAndRigs(const std::vector<Reconstruction*>& reconstructions,
                        const FrameSources& frame_sources,
                        Reconstruction* merged) {
  std::unordered_map<camera_t, std::pair<size_t, size_t>> camera_source;
  std::unordered_map<rig_t, std::pair<size_t, size_t>> rig_source;
  std::vector<std::unordered_map<rig_t, size_t>> num_frames_of_rig(
      reconstructions.size());
  for (size_t r = 0; r < reconstructions.size(); ++r) {
    const Reconstruction& reconstruction = *reconstructions[r];
    std::unordered_map<camera_t, size_t> num_images_per_camera;
    for (const frame_t frame_id : reconstruction.RegFrameIds()) {
      if (!frame_sources.Takes(r, frame_id)) {
        continue;
      }
      const Frame& frame = reconstruction.Frame(frame_id);
      ++num_frames_of_rig[r][frame.RigId()];
      for (const data_t& data_id : frame.ImageIds()) {
        ++num_images_per_camera[reconstruction.Image(data_id.id).CameraId()];
      }
    }
    for (const auto& [camera_id, num_images] : num_images_per_camera) {
      auto& source = camera_source[camera_id];
      if (num_images > source.second) {
        source = {r, num_images};
      }
    }
    for (const auto& [rig_id, num_frames] : num_frames_of_rig[r]) {
      auto& source = rig_source[rig_id];
      if (num_frames > source.second) {
        source = {r, num_frames};
      }
    }
  }
  for (const auto& [camera_id, source] : camera_source) {
    merged->AddCamera(reconstructions[source.first]->Camera(camera_id));
  }
  for (const auto& [rig_id, source] : rig_source) {
    const Reconstruction& reconstruction = *reconstructions[source.first];
    const Rig& rig = reconstruction.Rig(rig_id);
    for (const sensor_t& sensor_id : rig.SensorIds()) {
      if (sensor_id.type == SensorType::CAMERA &&
          !merged->ExistsCamera(sensor_id.id)) {
        merged->AddCamera(reconstruction.Camera(sensor_id.id));
      }
    }
    merged->AddRig(rig);
    AverageSensorPoses(
        reconstructions, num_frames_of_rig, rig_id, &merged->Rig(rig_id));
  }
}

// The frames each reconstruction gives and their images (keypoints without
// points), with their poses.
void JoinFrames(const std::vector<Reconstruction*>& reconstructions,
                const FrameSources& frame_sources,
                Reconstruction* merged) {
  for (size_t r = 0; r < reconstructions.size(); ++r) {
    const Reconstruction& reconstruction = *reconstructions[r];
    for (const frame_t frame_id : reconstruction.RegFrameIds()) {
      if (!frame_sources.Takes(r, frame_id)) {
        continue;
      }
      const Frame& frame = reconstruction.Frame(frame_id);
      Frame merged_frame = frame;
      merged_frame.ResetRigPtr();
      merged->AddFrame(std::move(merged_frame));  // Registered: it has a pose.
      for (const data_t& data_id : frame.ImageIds()) {
        Image merged_image = reconstruction.Image(data_id.id);
        merged_image.ResetCameraPtr();
        merged_image.ResetFramePtr();
        for (point2D_t idx = 0; idx < merged_image.NumPoints2D(); ++idx) {
          merged_image.ResetPoint3DForPoint2D(idx);
        }
        merged->AddImage(std::move(merged_image));
      }
    }
  }
}

}  // namespace

void JoinReconstructions(
    const std::vector<Reconstruction*>& reconstructions,
    const std::vector<Sim3d>& world_from_reconstruction,
    const std::vector<std::unordered_set<image_t>>& owned_image_ids,
    Reconstruction* merged) {
  THROW_CHECK_EQ(reconstructions.size(), world_from_reconstruction.size());
  THROW_CHECK_EQ(reconstructions.size(), owned_image_ids.size());
  THROW_CHECK_NOTNULL(merged);
  THROW_CHECK_EQ(merged->NumImages(), 0);

  for (size_t r = 0; r < reconstructions.size(); ++r) {
    reconstructions[r]->Transform(world_from_reconstruction[r]);
  }
  const FrameSources frame_sources(reconstructions, owned_image_ids);
  JoinCamerasAndRigs(reconstructions, frame_sources, merged);
  JoinFrames(reconstructions, frame_sources, merged);

  // Each point keeps its observations in the frames its reconstruction gives.
  for (size_t r = 0; r < reconstructions.size(); ++r) {
    const Reconstruction& reconstruction = *reconstructions[r];
    for (const auto& [point3D_id, point3D] : reconstruction.Points3D()) {
      Track track;
      for (const TrackElement& track_el : point3D.track.Elements()) {
        if (frame_sources.Takes(
                r, reconstruction.Image(track_el.image_id).FrameId())) {
          track.AddElement(track_el);
        }
      }
      if (track.Length() > 0) {
        merged->AddPoint3D(point3D.xyz, std::move(track), point3D.color);
      }
    }
  }
}

std::shared_ptr<Reconstruction> RestrictToImages(
    const std::unordered_set<image_t>& image_ids,
    std::shared_ptr<Reconstruction> reconstruction) {
  THROW_CHECK_NOTNULL(reconstruction);
  bool has_other_images = false;
  for (const image_t image_id : reconstruction->RegImageIds()) {
    has_other_images |= image_ids.count(image_id) == 0;
  }
  if (!has_other_images) {
    return reconstruction;
  }
  auto restricted = std::make_shared<Reconstruction>();
  JoinReconstructions(
      {reconstruction.get()}, {Sim3d()}, {image_ids}, restricted.get());
  for (const point3D_t point3D_id : restricted->Point3DIds()) {
    if (restricted->Point3D(point3D_id).track.Length() < 2) {
      restricted->DeletePoint3D(point3D_id);
    }
  }
  return restricted;
}

}  // namespace colmap
