#include "colmap_ext/testing/synthetic_scene.h"

#include "colmap_ext/testing/matched_pair_verification.h"
#include "colmap_ext/testing/model_evaluation.h"

#include "colmap/geometry/essential_matrix.h"
#include "colmap/geometry/pose.h"
#include "colmap/math/math.h"
#include "colmap/math/random.h"
#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <unordered_set>

namespace colmap {
namespace {

constexpr double kTowerRadius = 6.0;
constexpr double kTowerHeight = 15.0;
constexpr double kGroundRadius = 22.0;
constexpr double kRingMinRadius = 14.0;
constexpr double kRingMaxRadius = 24.0;
constexpr double kCameraHeight = 1.6;
constexpr double kWallHeight = 8.0;
constexpr double kWallDistance = 10.0;
constexpr double kMaxWalkwayTurnDeg = 60.0;
// The poster repeated on every wall: its width along the wall, the height of
// its lower edge and its own height.
constexpr double kPosterWidth = 5.0;
constexpr double kPosterBottom = 1.0;
constexpr double kPosterHeight = 4.0;
// A surface point is seen up to this angle between its normal and the ray.
constexpr double kMaxSurfaceViewingAngleDeg = 80.0;

class Random {
 public:
  explicit Random(unsigned int seed) : engine_(seed) {}
  // Own transforms of the engine's integers: the standard distributions are
  // implementation-defined, and the same seed must give the same bytes.
  double Uniform(double min, double max) {
    const double unit = static_cast<double>(engine_() >> 11) *
                        (1.0 / 9007199254740992.0);  // 2^-53
    return min + (max - min) * unit;
  }
  double Gaussian(double stddev) {
    // Box-Muller.
    const double u1 = std::max(Uniform(0, 1), 1e-300);
    const double u2 = Uniform(0, 1);
    return stddev * std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * M_PI * u2);
  }
  int Integer(int min, int max) {  // inclusive
    return min +
           static_cast<int>(engine_() % static_cast<uint64_t>(max - min + 1));
  }
  template <typename T>
  void Shuffle(std::vector<T>* values) {
    for (size_t i = values->size(); i > 1; --i) {
      std::swap((*values)[i - 1],
                (*values)[Integer(0, static_cast<int>(i) - 1)]);
    }
  }

 private:
  std::mt19937_64 engine_;
};

struct ScenePoint {
  Eigen::Vector3d xyz;
  // Zero for features visible from every side.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

// Repeated patterns whose copies stand in several places of the scene.
constexpr int kTowerPattern = 0;
constexpr int kPosterPattern = 1;
constexpr int kNumPatterns = 2;

// A point's place in a repeated pattern: the pattern, its index in the
// pattern's layout and the copy it belongs to; pattern -1: no pattern.
struct PatternPoint {
  int pattern = -1;
  int index = -1;
  int copy = -1;
};

struct ScenePose {
  Rigid3d cam_from_world;
  int cluster = -1;
};

// Whether the segment from a to b passes through a tower (in the ground
// plane; towers are taller than anything behind them). A point on a tower's
// surface that faces a is not hidden by its own tower: the segment only
// touches the tower at its end.
bool HiddenByTower(const Eigen::Vector3d& a,
                   const Eigen::Vector3d& b,
                   const std::vector<Eigen::Vector2d>& towers) {
  const Eigen::Vector2d a2 = a.head<2>();
  const Eigen::Vector2d d = b.head<2>() - a2;
  const double length_sq = std::max(d.squaredNorm(), 1e-12);
  for (const Eigen::Vector2d& tower : towers) {
    const double t =
        std::min(1.0, std::max(0.0, (tower - a2).dot(d) / length_sq));
    if ((a2 + t * d - tower).norm() < kTowerRadius - 0.05) {
      return true;
    }
  }
  return false;
}

}  // namespace

Rigid3d LookAt(const Eigen::Vector3d& center,
               const Eigen::Vector3d& target,
               const double roll) {
  const Eigen::Vector3d forward = (target - center).normalized();
  const Eigen::Vector3d right =
      forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d R;
  R.row(0) = right.transpose();
  R.row(1) = down.transpose();
  R.row(2) = forward.transpose();
  R = Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R;
  return Rigid3d(Eigen::Quaterniond(R), -(R * center));
}

bool SyntheticSceneOptions::Check() const {
  CHECK_OPTION_GE(num_clusters, 1);
  CHECK_OPTION_GE(num_images_per_cluster, 2);
  CHECK_OPTION_GE(num_images_per_link, 0);
  CHECK_OPTION_GT(landmark_spacing, 2 * kRingMaxRadius);
  CHECK_OPTION_GE(num_points_per_cluster, 10);
  CHECK_OPTION_GE(num_points_per_link, 0);
  CHECK_OPTION_GT(image_width, 0);
  CHECK_OPTION_GT(image_height, 0);
  CHECK_OPTION_GT(focal_length, 0);
  CHECK_OPTION_GE(num_rig_cameras, 1);
  // A rig's cameras are its sensors: one Camera each, shared by its images.
  CHECK_OPTION(single_camera || num_rig_cameras == 1);
  CHECK_OPTION_GT(rig_baseline, 0);
  CHECK_OPTION_LT(std::abs(rig_yaw_deg), 45.0);
  CHECK_OPTION_GE(focal_length_noise, 0);
  CHECK_OPTION_LT(focal_length_noise, 0.3);
  CHECK_OPTION_GE(keypoint_noise, 0);
  CHECK_OPTION_GE(num_distractor_keypoints, 0);
  CHECK_OPTION_GT(max_viewing_distance, 0);
  CHECK_OPTION_GE(min_num_shared_points, 1);
  CHECK_OPTION_GE(wrong_match_fraction, 0);
  CHECK_OPTION_LT(wrong_match_fraction, 0.9);
  CHECK_OPTION_GE(epipolar_wrong_match_share, 0);
  CHECK_OPTION_LE(epipolar_wrong_match_share, 1);
  CHECK_OPTION_GE(num_false_pairs, 0);
  CHECK_OPTION_GE(false_pair_num_matches, 1);
  CHECK_OPTION_GE(num_repeated_structure_pairs, 0);
  CHECK_OPTION_GE(num_repeated_texture_pairs, 0);
  // Copies of the poster stand on two walls at least.
  CHECK_OPTION(num_repeated_texture_pairs == 0 ||
               (num_images_per_link > 0 && num_clusters >= 3));
  return true;
}

void SynthesizeCommunityScene(const SyntheticSceneOptions& options,
                              SyntheticScene* scene,
                              Database* database) {
  THROW_CHECK(options.Check());
  THROW_CHECK_NOTNULL(scene);
  if (database != nullptr) {
    THROW_CHECK_EQ(database->NumImages(), 0)
        << "The scene must be written to an empty database.";
  }
  Random random(options.seed);
  *scene = SyntheticScene();
  Reconstruction& reconstruction = scene->ground_truth;

  //////////////////////////////////////////////////////////////////////////////
  // Landmarks and walkways
  //////////////////////////////////////////////////////////////////////////////

  const int num_clusters = options.num_clusters;
  std::vector<Eigen::Vector2d> towers(num_clusters);
  if (num_clusters == 1) {
    towers[0].setZero();
  } else if (num_clusters == 2) {
    towers[0] = Eigen::Vector2d(-options.landmark_spacing / 2, 0);
    towers[1] = Eigen::Vector2d(options.landmark_spacing / 2, 0);
  } else {
    const double radius =
        options.landmark_spacing / (2 * std::sin(M_PI / num_clusters));
    for (int c = 0; c < num_clusters; ++c) {
      const double angle = 2 * M_PI * c / num_clusters;
      towers[c] = radius * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
  }

  std::vector<std::pair<int, int>> links;
  for (int c = 0; c + 1 < num_clusters; ++c) {
    links.emplace_back(c, c + 1);
  }
  if (options.close_loop && num_clusters >= 3) {
    links.emplace_back(num_clusters - 1, 0);
  }
  if (options.num_images_per_link == 0) {
    links.clear();
  }

  // With repeated structure, every tower is a copy of the first: tower
  // point i of every landmark has the same angle and height. With repeated
  // texture, every wall carries the same poster.
  const bool repeated_towers = options.num_repeated_structure_pairs > 0;
  const bool posters = options.num_repeated_texture_pairs > 0;
  const int num_tower_points = (7 * options.num_points_per_cluster) / 10;
  std::vector<std::pair<double, double>> tower_layout;
  std::vector<ScenePoint> points;
  // Per point: where it lies in a repeated pattern, if it does.
  std::vector<PatternPoint> pattern_points;
  // Per pattern: where each of its copies stands in the world (towers:
  // landmark c's copy at its centre; posters: wall l's copy at the foot of
  // the wall below the poster's centre, x along the wall, y towards it, z
  // up).
  std::vector<Rigid3d> world_from_copy[kNumPatterns];
  for (int c = 0; c < num_clusters; ++c) {
    world_from_copy[kTowerPattern].emplace_back(
        Eigen::Quaterniond::Identity(),
        Eigen::Vector3d(towers[c].x(), towers[c].y(), 0));
    for (int i = 0; i < options.num_points_per_cluster; ++i) {
      ScenePoint point;
      PatternPoint pattern_point;
      if (i < num_tower_points) {
        if (c == 0 || !repeated_towers) {
          const double angle = random.Uniform(0, 2 * M_PI);
          tower_layout.emplace_back(angle, random.Uniform(0, kTowerHeight));
        }
        const std::pair<double, double>& layout =
            tower_layout[repeated_towers ? i : tower_layout.size() - 1];
        const double angle = layout.first;
        const double height = layout.second;
        const Eigen::Vector3d radial(std::cos(angle), std::sin(angle), 0);
        point.xyz = Eigen::Vector3d(towers[c].x(), towers[c].y(), 0) +
                    kTowerRadius * radial + Eigen::Vector3d(0, 0, height);
        point.normal = radial;
        if (repeated_towers) {
          pattern_point = {kTowerPattern, i, c};
        }
      } else {
        const double angle = random.Uniform(0, 2 * M_PI);
        const double radius = std::sqrt(random.Uniform(
            kTowerRadius * kTowerRadius, kGroundRadius * kGroundRadius));
        point.xyz = Eigen::Vector3d(towers[c].x() + radius * std::cos(angle),
                                    towers[c].y() + radius * std::sin(angle),
                                    0);
        point.normal = Eigen::Vector3d::UnitZ();
      }
      points.push_back(point);
      pattern_points.push_back(pattern_point);
    }
  }
  // Each walkway is lined on its left by a wall from tower to tower, tangent
  // to both, facing the walkway.
  // The poster is part of its wall: it replaces the wall's own points where
  // it hangs, at the same density (every wall is landmark_spacing long).
  const int num_poster_points =
      posters ? static_cast<int>(std::round(
                    options.num_points_per_link * kPosterWidth *
                    kPosterHeight /
                    (options.landmark_spacing * kWallHeight)))
              : 0;
  std::vector<Eigen::Vector2d> poster_layout;
  for (int i = 0; i < num_poster_points; ++i) {
    poster_layout.emplace_back(
        random.Uniform(-kPosterWidth / 2, kPosterWidth / 2),
        random.Uniform(kPosterBottom, kPosterBottom + kPosterHeight));
  }
  for (size_t l = 0; l < links.size(); ++l) {
    const Eigen::Vector2d from = towers[links[l].first];
    const Eigen::Vector2d to = towers[links[l].second];
    const Eigen::Vector2d along = (to - from).normalized();
    const Eigen::Vector2d left(-along.y(), along.x());
    const double length = (to - from).norm();
    const Eigen::Vector3d normal(-left.x(), -left.y(), 0);
    // Where along the wall the poster hangs: anywhere on its middle half, so
    // that no symmetry of the scene maps one copy onto another.
    const double poster_position =
        posters ? random.Uniform(0.25 * length, 0.75 * length) : 0;
    for (int i = 0; i < options.num_points_per_link; ++i) {
      const double position = random.Uniform(0, length);
      const double height = random.Uniform(0, kWallHeight);
      if (posters && std::abs(position - poster_position) < kPosterWidth / 2 &&
          height > kPosterBottom && height < kPosterBottom + kPosterHeight) {
        continue;  // Covered by the poster.
      }
      const Eigen::Vector2d xy =
          from + position * along + kTowerRadius * left;
      ScenePoint point;
      point.xyz = Eigen::Vector3d(xy.x(), xy.y(), height);
      point.normal = normal;
      points.push_back(point);
      pattern_points.emplace_back();
    }
    Eigen::Matrix3d poster_axes;
    poster_axes.col(0) = Eigen::Vector3d(along.x(), along.y(), 0);
    poster_axes.col(1) = Eigen::Vector3d(left.x(), left.y(), 0);
    poster_axes.col(2) = Eigen::Vector3d::UnitZ();
    const Eigen::Vector2d foot = from + poster_position * along;
    const Rigid3d world_from_poster(Eigen::Quaterniond(poster_axes),
                                    Eigen::Vector3d(foot.x(), foot.y(), 0));
    world_from_copy[kPosterPattern].push_back(world_from_poster);
    for (int i = 0; i < num_poster_points; ++i) {
      ScenePoint point;
      point.xyz = world_from_poster * Eigen::Vector3d(poster_layout[i].x(),
                                                      kTowerRadius,
                                                      poster_layout[i].y());
      point.normal = normal;
      points.push_back(point);
      pattern_points.push_back({kPosterPattern, i, static_cast<int>(l)});
    }
  }

  //////////////////////////////////////////////////////////////////////////////
  // Camera poses
  //////////////////////////////////////////////////////////////////////////////

  const double kDegToRad = M_PI / 180.0;
  std::vector<ScenePose> poses;
  for (int c = 0; c < num_clusters; ++c) {
    for (int i = 0; i < options.num_images_per_cluster; ++i) {
      const double angle = random.Uniform(0, 2 * M_PI);
      const double radius = random.Uniform(kRingMinRadius, kRingMaxRadius);
      const Eigen::Vector3d center(towers[c].x() + radius * std::cos(angle),
                                   towers[c].y() + radius * std::sin(angle),
                                   kCameraHeight + random.Uniform(-0.3, 0.3));
      const Eigen::Vector3d target(towers[c].x() + random.Uniform(-2, 2),
                                   towers[c].y() + random.Uniform(-2, 2),
                                   random.Uniform(3, 8));
      poses.push_back(
          {LookAt(center, target, random.Uniform(-3, 3) * kDegToRad), c});
    }
  }
  // Walkway cameras walk 10 m from the wall, looking at it; over the first
  // and last quarter of the walk they turn towards the tower behind or ahead,
  // so that the walk starts and ends with views of the towers.
  for (const auto& link : links) {
    const Eigen::Vector2d from = towers[link.first];
    const Eigen::Vector2d to = towers[link.second];
    const Eigen::Vector2d along = (to - from).normalized();
    const Eigen::Vector2d left(-along.y(), along.x());
    const double start = kRingMinRadius;
    const double end = (to - from).norm() - kRingMinRadius;
    for (int i = 0; i < options.num_images_per_link; ++i) {
      const double t = (i + 0.5) / options.num_images_per_link;
      const Eigen::Vector2d xy =
          from + (start + t * (end - start)) * along +
          (kTowerRadius - kWallDistance + random.Uniform(-1, 1)) * left;
      const Eigen::Vector3d center(
          xy.x(), xy.y(), kCameraHeight + random.Uniform(-0.2, 0.2));
      const double turn =
          kMaxWalkwayTurnDeg * (std::max(0.0, (t - 0.75) / 0.25) -
                                std::max(0.0, 1.0 - t / 0.25)) +
          random.Uniform(-10, 10);
      const Eigen::Vector2d heading = std::cos(turn * kDegToRad) * left +
                                      std::sin(turn * kDegToRad) * along;
      const Eigen::Vector3d target =
          center + Eigen::Vector3d(heading.x(),
                                   heading.y(),
                                   std::tan(random.Uniform(0, 10) * kDegToRad));
      poses.push_back(
          {LookAt(center, target, random.Uniform(-3, 3) * kDegToRad), -1});
    }
  }
  random.Shuffle(&poses);

  //////////////////////////////////////////////////////////////////////////////
  // Cameras, images and observations
  //////////////////////////////////////////////////////////////////////////////

  const Camera camera_template =
      Camera::CreateFromModelName(kInvalidCameraId,
                                  "SIMPLE_RADIAL",
                                  options.focal_length,
                                  options.image_width,
                                  options.image_height);
  // The database holds the nominal focal length as a prior (as from EXIF),
  // the ground truth the camera's true one. Returns the camera.
  auto add_camera = [&]() {
    Camera camera = camera_template;
    camera.has_prior_focal_length = true;
    camera.camera_id =
        database != nullptr
            ? database->WriteCamera(camera)
            : static_cast<camera_t>(reconstruction.NumCameras() + 1);
    if (options.focal_length_noise > 0) {
      const double factor =
          std::max(0.5, 1.0 + random.Gaussian(options.focal_length_noise));
      camera.SetFocalLength(factor * options.focal_length);
    }
    reconstruction.AddCamera(camera);
    return camera.camera_id;
  };

  // Where camera k of the rig stands in it: rig_baseline * k to the right of
  // the reference camera (k = 0, the rig's frame), turned right by
  // rig_yaw_deg * k about its vertical axis.
  std::vector<Rigid3d> sensors_from_rig;
  for (int k = 0; k < options.num_rig_cameras; ++k) {
    const Eigen::Quaterniond rotation(Eigen::AngleAxisd(
        -k * options.rig_yaw_deg * kDegToRad, Eigen::Vector3d::UnitY()));
    sensors_from_rig.emplace_back(
        rotation,
        -(rotation * Eigen::Vector3d(k * options.rig_baseline, 0, 0)));
  }

  // A rig of the given cameras, the first its reference sensor, the others
  // at their true sensor_from_rig, which the database holds as well (as
  // rig_configurator writes a configuration with known poses). A single
  // camera is the only sensor of a rig of its own, as the feature extractor
  // writes them. Returns the rig.
  auto add_rig = [&](const std::vector<camera_t>& camera_ids) {
    Rig rig;
    rig.AddRefSensor(reconstruction.Camera(camera_ids[0]).SensorId());
    for (size_t k = 1; k < camera_ids.size(); ++k) {
      rig.AddSensor(reconstruction.Camera(camera_ids[k]).SensorId(),
                    sensors_from_rig[k]);
    }
    rig.SetRigId(database != nullptr
                     ? database->WriteRig(rig)
                     : static_cast<rig_t>(reconstruction.NumRigs() + 1));
    reconstruction.AddRig(rig);
    return rig.RigId();
  };

  for (size_t i = 0; i < points.size(); ++i) {
    reconstruction.AddPoint3D(static_cast<point3D_t>(i + 1), Point3D());
    reconstruction.Point3D(static_cast<point3D_t>(i + 1)).xyz = points[i].xyz;
  }

  const double min_cos_surface =
      std::cos(kMaxSurfaceViewingAngleDeg * kDegToRad);
  rig_t shared_rig_id = kInvalidRigId;
  std::vector<camera_t> shared_camera_ids;
  // Per image: the ids of the observed points, sorted, with their keypoint.
  std::vector<std::vector<std::pair<point3D_t, point2D_t>>> observations;
  std::vector<image_t> image_ids;
  std::vector<point2D_t> num_keypoints;

  for (size_t pose_idx = 0; pose_idx < poses.size(); ++pose_idx) {
    const ScenePose& pose = poses[pose_idx];
    // The cameras of the frame's rig, the reference camera first.
    std::vector<camera_t> camera_ids;
    rig_t rig_id;
    if (options.single_camera) {
      if (shared_rig_id == kInvalidRigId) {
        for (int k = 0; k < options.num_rig_cameras; ++k) {
          shared_camera_ids.push_back(add_camera());
        }
        shared_rig_id = add_rig(shared_camera_ids);
      }
      camera_ids = shared_camera_ids;
      rig_id = shared_rig_id;
    } else {
      camera_ids.push_back(add_camera());
      rig_id = add_rig(camera_ids);
    }

    // One image per camera of the rig, all in one frame (one snapshot of
    // the rig) whose pose is the reference camera's.
    Frame frame;
    frame.SetRigId(rig_id);
    std::vector<Image> frame_images;
    for (size_t k = 0; k < camera_ids.size(); ++k) {
      const Camera& camera = reconstruction.Camera(camera_ids[k]);
      const Rigid3d cam_from_world =
          k == 0 ? pose.cam_from_world
                 : sensors_from_rig[k] * pose.cam_from_world;
      const Eigen::Vector3d center = cam_from_world.TgtOriginInSrc();

      std::vector<Point2D> points2D;
      for (size_t i = 0; i < points.size(); ++i) {
        const ScenePoint& point = points[i];
        const Eigen::Vector3d ray = center - point.xyz;
        const double distance = ray.norm();
        if (distance > options.max_viewing_distance) {
          continue;
        }
        if (!point.normal.isZero() &&
            point.normal.dot(ray) < min_cos_surface * distance) {
          continue;
        }
        const Eigen::Vector3d point_in_cam = cam_from_world * point.xyz;
        if (point_in_cam.z() < 0.5) {
          continue;
        }
        const Eigen::Vector2d xy =
            *camera.ImgFromCam(point_in_cam) +
            Eigen::Vector2d(random.Gaussian(options.keypoint_noise),
                            random.Gaussian(options.keypoint_noise));
        if (xy.x() < 0 || xy.y() < 0 || xy.x() >= camera.width ||
            xy.y() >= camera.height) {
          continue;
        }
        if (HiddenByTower(center, point.xyz, towers)) {
          continue;
        }
        Point2D point2D;
        point2D.xy = xy;
        point2D.point3D_id = static_cast<point3D_t>(i + 1);
        points2D.push_back(point2D);
      }
      for (int i = 0; i < options.num_distractor_keypoints; ++i) {
        Point2D point2D;
        point2D.xy = Eigen::Vector2d(random.Uniform(0, camera.width),
                                     random.Uniform(0, camera.height));
        points2D.push_back(point2D);
      }
      random.Shuffle(&points2D);

      // A rig's images are named by camera folder, as rig_configurator
      // expects them: the same name after the folder makes one frame.
      Image image;
      const std::string name =
          StringPrintf("image%05d.jpg", static_cast<int>(pose_idx));
      image.SetName(options.num_rig_cameras > 1
                        ? StringPrintf("cam%d/", static_cast<int>(k)) + name
                        : name);
      image.SetCameraId(camera_ids[k]);
      const image_t image_id =
          database != nullptr
              ? database->WriteImage(image)
              : static_cast<image_t>(image_ids.size() + k + 1);
      image.SetImageId(image_id);
      image.SetPoints2D(points2D);
      frame.AddDataId(image.DataId());
      frame_images.push_back(std::move(image));
    }
    frame.SetFrameId(database != nullptr ? database->WriteFrame(frame)
                                         : static_cast<frame_t>(pose_idx + 1));
    frame.SetRigFromWorld(pose.cam_from_world);
    const frame_t frame_id = frame.FrameId();
    // Added with its pose, the frame is registered.
    reconstruction.AddFrame(std::move(frame));

    for (Image& image : frame_images) {
      const image_t image_id = image.ImageId();
      image.SetFrameId(frame_id);
      if (database != nullptr) {
        FeatureKeypoints keypoints;
        keypoints.reserve(image.NumPoints2D());
        for (const Point2D& point2D : image.Points2D()) {
          keypoints.emplace_back(static_cast<float>(point2D.xy.x()),
                                 static_cast<float>(point2D.xy.y()));
        }
        database->WriteKeypoints(image_id, keypoints);
      }

      std::vector<std::pair<point3D_t, point2D_t>> image_observations;
      for (point2D_t point2D_idx = 0; point2D_idx < image.NumPoints2D();
           ++point2D_idx) {
        const point3D_t point3D_id = image.Point2D(point2D_idx).point3D_id;
        if (point3D_id != kInvalidPoint3DId) {
          image_observations.emplace_back(point3D_id, point2D_idx);
          reconstruction.Point3D(point3D_id)
              .track.AddElement(image_id, point2D_idx);
        }
      }
      std::sort(image_observations.begin(), image_observations.end());
      observations.push_back(std::move(image_observations));
      image_ids.push_back(image_id);
      num_keypoints.push_back(static_cast<point2D_t>(image.NumPoints2D()));
      reconstruction.AddImage(std::move(image));
      scene->image_cluster.emplace(image_id, pose.cluster);
    }
  }

  // Points seen by fewer than two cameras are no part of the ground truth.
  for (const point3D_t point3D_id : reconstruction.Point3DIds()) {
    if (reconstruction.Point3D(point3D_id).track.Length() < 2) {
      reconstruction.DeletePoint3D(point3D_id);
    }
  }

  //////////////////////////////////////////////////////////////////////////////
  // Raw matches
  //////////////////////////////////////////////////////////////////////////////

  const size_t num_images = image_ids.size();

  // The two-view geometry of images idx1 and idx2 if the second one's view
  // were taken `second_from_first` away (identity: the true one).
  auto exact_two_view_geometry = [&](const size_t idx1,
                                     const size_t idx2,
                                     const Rigid3d& second_from_first) {
    const Image& image1 = reconstruction.Image(image_ids[idx1]);
    const Image& image2 = reconstruction.Image(image_ids[idx2]);
    TwoViewGeometry two_view_geometry;
    two_view_geometry.config = TwoViewGeometry::CALIBRATED;
    two_view_geometry.cam2_from_cam1 = image2.CamFromWorld() *
                                       second_from_first *
                                       Inverse(image1.CamFromWorld());
    two_view_geometry.E =
        EssentialMatrixFromPose(*two_view_geometry.cam2_from_cam1);
    two_view_geometry.F = FundamentalFromEssentialMatrix(
        reconstruction.Camera(image2.CameraId()).CalibrationMatrix(),
        *two_view_geometry.E,
        reconstruction.Camera(image1.CameraId()).CalibrationMatrix());
    return two_view_geometry;
  };

  // The keypoints of images idx1 and idx2 that no match of `matches` uses,
  // each list shuffled.
  auto shuffled_free_keypoints = [&](const size_t idx1,
                                     const size_t idx2,
                                     const FeatureMatches& matches) {
    std::vector<char> used1(num_keypoints[idx1], 0);
    std::vector<char> used2(num_keypoints[idx2], 0);
    for (const FeatureMatch& match : matches) {
      used1[match.point2D_idx1] = 1;
      used2[match.point2D_idx2] = 1;
    }
    std::pair<std::vector<point2D_t>, std::vector<point2D_t>> free;
    for (point2D_t i = 0; i < num_keypoints[idx1]; ++i) {
      if (!used1[i]) free.first.push_back(i);
    }
    for (point2D_t i = 0; i < num_keypoints[idx2]; ++i) {
      if (!used2[i]) free.second.push_back(i);
    }
    random.Shuffle(&free.first);
    random.Shuffle(&free.second);
    return free;
  };

  // Random one-to-one matches between keypoints not used by `matches`.
  auto add_random_matches = [&](const size_t idx1,
                                const size_t idx2,
                                const int num_matches,
                                FeatureMatches* matches) {
    const auto [free1, free2] = shuffled_free_keypoints(idx1, idx2, *matches);
    const size_t num_added =
        std::min<size_t>(num_matches, std::min(free1.size(), free2.size()));
    for (size_t i = 0; i < num_added; ++i) {
      matches->emplace_back(free1[i], free2[i]);
    }
  };

  // As add_random_matches, but each wrong match pairs a keypoint of image
  // idx1 with a free keypoint of image idx2 that lies within
  // kMaxEpipolarError pixels of its epipolar line (the true geometry's).
  constexpr double kMaxEpipolarError = 4.0;
  auto add_epipolar_matches = [&](const size_t idx1,
                                  const size_t idx2,
                                  const int num_matches,
                                  FeatureMatches* matches) {
    const Image& image1 = reconstruction.Image(image_ids[idx1]);
    const Image& image2 = reconstruction.Image(image_ids[idx2]);
    const Eigen::Matrix3d F =
        *exact_two_view_geometry(idx1, idx2, Rigid3d()).F;
    auto [free1, free2] = shuffled_free_keypoints(idx1, idx2, *matches);
    int num_added = 0;
    for (const point2D_t point2D_idx1 : free1) {
      if (num_added == num_matches) {
        break;
      }
      const Eigen::Vector3d line =
          F * image1.Point2D(point2D_idx1).xy.homogeneous();
      const double norm = line.head<2>().norm();
      for (point2D_t& point2D_idx2 : free2) {
        if (point2D_idx2 == kInvalidPoint2DIdx ||
            std::abs(line.dot(image2.Point2D(point2D_idx2).xy.homogeneous())) >
                kMaxEpipolarError * norm) {
          continue;
        }
        matches->emplace_back(point2D_idx1, point2D_idx2);
        point2D_idx2 = kInvalidPoint2DIdx;  // Used.
        ++num_added;
        break;
      }
    }
  };

  // The matcher's wrong matches added to a pair's matches, shuffled.
  auto add_wrong_matches = [&](const size_t idx1,
                               const size_t idx2,
                               FeatureMatches* matches) {
    const double wrong_per_match =
        options.wrong_match_fraction / (1.0 - options.wrong_match_fraction);
    const int num_wrong =
        static_cast<int>(std::round(wrong_per_match * matches->size()));
    const int num_epipolar = static_cast<int>(
        std::round(options.epipolar_wrong_match_share * num_wrong));
    add_epipolar_matches(idx1, idx2, num_epipolar, matches);
    add_random_matches(idx1, idx2, num_wrong - num_epipolar, matches);
    random.Shuffle(matches);
  };

  // A matched pair's raw matches written; with exact two-view geometries
  // also as verified, at the pose of the second view taken
  // `second_from_first` away.
  auto write_pair = [&](const size_t idx1,
                        const size_t idx2,
                        FeatureMatches matches,
                        const Rigid3d& second_from_first) {
    database->WriteMatches(image_ids[idx1], image_ids[idx2], matches);
    scene->num_raw_matches += matches.size();
    if (options.exact_two_view_geometries) {
      TwoViewGeometry two_view_geometry =
          exact_two_view_geometry(idx1, idx2, second_from_first);
      two_view_geometry.inlier_matches = std::move(matches);
      ++scene->num_verified_pairs;
      scene->num_inlier_matches += two_view_geometry.inlier_matches.size();
      database->WriteTwoViewGeometry(
          image_ids[idx1], image_ids[idx2], two_view_geometry);
    }
  };

  std::unique_ptr<DatabaseTransaction> transaction;
  if (database != nullptr) {
    transaction = std::make_unique<DatabaseTransaction>(database);
  }

  // Observers of every point, in ascending image index.
  std::unordered_map<point3D_t, std::vector<std::pair<size_t, point2D_t>>>
      observers;
  for (size_t idx = 0; idx < num_images; ++idx) {
    for (const auto& observation : observations[idx]) {
      observers[observation.first].emplace_back(idx, observation.second);
    }
  }

  // Pairs that share at least one point, as idx1 * num_images + idx2.
  std::unordered_set<uint64_t> sharing_pairs;
  std::vector<FeatureMatches> matches_with(num_images);
  for (size_t idx1 = 0; idx1 < num_images; ++idx1) {
    std::vector<size_t> partners;
    for (const auto& observation : observations[idx1]) {
      for (const auto& observer : observers.at(observation.first)) {
        if (observer.first <= idx1) {
          continue;
        }
        FeatureMatches& matches = matches_with[observer.first];
        if (matches.empty()) {
          partners.push_back(observer.first);
        }
        matches.emplace_back(observation.second, observer.second);
      }
    }
    std::sort(partners.begin(), partners.end());
    for (const size_t idx2 : partners) {
      FeatureMatches matches = std::move(matches_with[idx2]);
      matches_with[idx2].clear();
      sharing_pairs.insert(idx1 * num_images + idx2);
      if (static_cast<int>(matches.size()) < options.min_num_shared_points) {
        continue;
      }
      ++scene->num_matched_pairs;
      if (database != nullptr) {
        add_wrong_matches(idx1, idx2, &matches);
        write_pair(idx1, idx2, std::move(matches), Rigid3d());
      }
    }
  }

  // Pairs of images that share no point, matched by chance.
  const int kMaxAttemptsPerPair = 1000;
  for (int i = 0; i < options.num_false_pairs && num_images >= 2; ++i) {
    for (int attempt = 0; attempt < kMaxAttemptsPerPair; ++attempt) {
      size_t idx1 = random.Integer(0, static_cast<int>(num_images) - 1);
      size_t idx2 = random.Integer(0, static_cast<int>(num_images) - 1);
      if (idx1 == idx2) {
        continue;
      }
      if (idx1 > idx2) {
        std::swap(idx1, idx2);
      }
      if (!sharing_pairs.insert(idx1 * num_images + idx2).second) {
        continue;  // Shares points or is already a false pair.
      }
      ++scene->num_matched_pairs;
      ++scene->num_false_pairs;
      if (database != nullptr) {
        FeatureMatches matches;
        add_random_matches(
            idx1, idx2, options.false_pair_num_matches, &matches);
        write_pair(idx1, idx2, std::move(matches), Rigid3d());
      }
      break;
    }
  }

  // Pairs of images that share no point, matched on repeated structure or
  // texture: on the points of one copy of a pattern that the first image
  // sees and of another copy that the second sees, at the same places of
  // the pattern's layout.
  const int num_pattern_pairs[kNumPatterns] = {
      options.num_repeated_structure_pairs, options.num_repeated_texture_pairs};
  int* num_written_pattern_pairs[kNumPatterns] = {
      &scene->num_repeated_structure_pairs,
      &scene->num_repeated_texture_pairs};
  for (int pattern = 0; pattern < kNumPatterns; ++pattern) {
    if (num_pattern_pairs[pattern] == 0) {
      continue;
    }
    // Per image: layout index -> (copy, keypoint); per layout index: the
    // images that see it.
    std::vector<std::unordered_map<int, std::pair<int, point2D_t>>>
        pattern_keypoints(num_images);
    std::unordered_map<int, std::vector<size_t>> seen_by;
    for (size_t idx = 0; idx < num_images; ++idx) {
      for (const auto& observation : observations[idx]) {
        const PatternPoint& point = pattern_points[observation.first - 1];
        if (point.pattern == pattern &&
            pattern_keypoints[idx]
                .emplace(point.index,
                         std::make_pair(point.copy, observation.second))
                .second) {
          seen_by[point.index].push_back(idx);
        }
      }
    }
    // Per pair and two copies: the number of layout places in common.
    const uint64_t num_copies = world_from_copy[pattern].size();
    std::unordered_map<uint64_t, int> num_common;
    for (const auto& [index, image_idxs] : seen_by) {
      for (size_t i = 0; i < image_idxs.size(); ++i) {
        const int copy1 = pattern_keypoints[image_idxs[i]].at(index).first;
        for (size_t j = i + 1; j < image_idxs.size(); ++j) {
          const int copy2 = pattern_keypoints[image_idxs[j]].at(index).first;
          if (copy1 != copy2) {
            ++num_common[((image_idxs[i] * num_images + image_idxs[j]) *
                              num_copies +
                          copy1) *
                             num_copies +
                         copy2];
          }
        }
      }
    }
    // Candidates (pair, copy1, copy2): the copies the pair has most places
    // in common on, at least min_num_shared_points.
    std::map<uint64_t, std::pair<int, uint64_t>> best_copies;
    for (const auto& [key, count] : num_common) {
      const uint64_t pair = key / (num_copies * num_copies);
      if (count < options.min_num_shared_points ||
          sharing_pairs.count(pair) > 0) {
        continue;
      }
      auto& best = best_copies[pair];
      if (count > best.first ||
          (count == best.first && key % (num_copies * num_copies) <
                                      best.second)) {
        best = {count, key % (num_copies * num_copies)};
      }
    }
    std::vector<std::pair<uint64_t, uint64_t>> candidates;
    for (const auto& [pair, best] : best_copies) {
      candidates.emplace_back(pair, best.second);
    }
    random.Shuffle(&candidates);
    candidates.resize(
        std::min<size_t>(candidates.size(), num_pattern_pairs[pattern]));
    std::sort(candidates.begin(), candidates.end());
    for (const auto& [pair, copies] : candidates) {
      const size_t idx1 = pair / num_images;
      const size_t idx2 = pair % num_images;
      const int copy1 = static_cast<int>(copies / num_copies);
      const int copy2 = static_cast<int>(copies % num_copies);
      sharing_pairs.insert(pair);
      ++scene->num_matched_pairs;
      ++*num_written_pattern_pairs[pattern];
      if (database == nullptr) {
        continue;
      }
      FeatureMatches matches;
      for (const auto& [index, copy_and_keypoint1] :
           pattern_keypoints[idx1]) {
        const auto it = pattern_keypoints[idx2].find(index);
        if (copy_and_keypoint1.first == copy1 &&
            it != pattern_keypoints[idx2].end() &&
            it->second.first == copy2) {
          matches.emplace_back(copy_and_keypoint1.second, it->second.second);
        }
      }
      std::sort(matches.begin(),
                matches.end(),
                [](const FeatureMatch& a, const FeatureMatch& b) {
                  return a.point2D_idx1 < b.point2D_idx1;
                });
      add_wrong_matches(idx1, idx2, &matches);
      write_pair(idx1,
                 idx2,
                 std::move(matches),
                 world_from_copy[pattern][copy2] *
                     Inverse(world_from_copy[pattern][copy1]));
    }
  }

  //////////////////////////////////////////////////////////////////////////////
  // Two-view geometries
  //////////////////////////////////////////////////////////////////////////////

  transaction.reset();
  if (database != nullptr && !options.exact_two_view_geometries) {
    const MatchedPairVerificationStats stats = VerifyMatchedPairs(
        TwoViewGeometryOptions(), options.seed, options.num_threads, database);
    scene->num_verified_pairs = stats.num_verified_pairs;
    scene->num_inlier_matches = stats.num_inlier_matches;
  }

  reconstruction.UpdatePoint3DErrors();
}

void WriteImageClusters(const SyntheticScene& scene, const std::string& path) {
  std::ofstream file(path);
  THROW_CHECK_FILE_OPEN(file, path);
  file << "# IMAGE_NAME CLUSTER (-1: walkway between landmarks)\n";
  std::vector<image_t> image_ids;
  for (const auto& image_and_cluster : scene.image_cluster) {
    image_ids.push_back(image_and_cluster.first);
  }
  std::sort(image_ids.begin(), image_ids.end());
  for (const image_t image_id : image_ids) {
    file << scene.ground_truth.Image(image_id).Name() << " "
         << scene.image_cluster.at(image_id) << "\n";
  }
}

void PerturbReconstruction(const double max_rotation_deg,
                           const double translation_fraction,
                           const double focal_length_factor,
                           const unsigned seed,
                           Reconstruction* reconstruction) {
  THROW_CHECK_NOTNULL(reconstruction);
  SetPRNGSeed(seed);
  auto random_vector = []() {
    return Eigen::Vector3d(RandomUniformReal(-1.0, 1.0),
                           RandomUniformReal(-1.0, 1.0),
                           RandomUniformReal(-1.0, 1.0));
  };
  const double step = translation_fraction *
                      EvaluateModel(*reconstruction, *reconstruction).extent;
  for (const frame_t frame_id : reconstruction->RegFrameIds()) {
    Rigid3d& rig_from_world = reconstruction->Frame(frame_id).RigFromWorld();
    const double angle =
        DegToRad(RandomUniformReal(-max_rotation_deg, max_rotation_deg));
    rig_from_world.rotation() = Eigen::Quaterniond(Eigen::AngleAxisd(
                                    angle, random_vector().normalized())) *
                                rig_from_world.rotation();
    rig_from_world.translation() += step * random_vector();
  }
  for (const point3D_t point3D_id : reconstruction->Point3DIds()) {
    reconstruction->Point3D(point3D_id).xyz += step * random_vector();
  }
  for (const auto& camera : reconstruction->Cameras()) {
    reconstruction->Camera(camera.first).params[0] *= focal_length_factor;
  }
}

}  // namespace colmap
