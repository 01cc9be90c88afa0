#include "colmap_ext/merge/covisibility_check.h"
#include "colmap_ext/merge/pairwise_similarity.h"
#include "colmap_ext/util/option_check.h"

#include "colmap/math/math.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace colmap {
namespace {

// The image is divided into kGridSize x kGridSize cells for its depth map.
constexpr int kGridSize = 16;

// One registered image in the common frame.
struct ImageView {
  image_t image_id = kInvalidImageId;
  const Camera* camera = nullptr;
  Sim3d cam_from_common;
  Eigen::Vector3d center;
  // Some of the 3D points it observes, in the common frame.
  std::vector<Eigen::Vector3d> points;
  // Per grid cell, the smallest depth of the points it observes there (0:
  // none): the surfaces it sees.
  std::vector<double> min_depth;

  int Cell(const Eigen::Vector2d& xy) const {
    const int col = std::min(
        kGridSize - 1, static_cast<int>(kGridSize * xy.x() / camera->width));
    const int row = std::min(
        kGridSize - 1, static_cast<int>(kGridSize * xy.y() / camera->height));
    return row * kGridSize + col;
  }
};

// The registered images, each with at most kMaxNumPoints of its points.
std::vector<ImageView> ImageViews(const Reconstruction& reconstruction,
                                  const Sim3d& common_from_model) {
  constexpr size_t kMaxNumPoints = 200;
  const Sim3d model_from_common = Inverse(common_from_model);
  std::vector<ImageView> views;
  views.reserve(reconstruction.NumRegImages());
  for (const image_t image_id : reconstruction.RegImageIds()) {
    const Image& image = reconstruction.Image(image_id);
    ImageView view;
    view.image_id = image_id;
    view.camera = &reconstruction.Camera(image.CameraId());
    const Rigid3d cam_from_model = image.CamFromWorld();
    view.cam_from_common =
        Sim3d(1, cam_from_model.rotation(), cam_from_model.translation()) *
        model_from_common;
    view.center = Inverse(view.cam_from_common).translation();
    std::vector<point3D_t> point3D_ids;
    view.min_depth.assign(kGridSize * kGridSize, 0.0);
    for (const Point2D& point2D : image.Points2D()) {
      if (point2D.HasPoint3D()) {
        point3D_ids.push_back(point2D.point3D_id);
        const double depth =
            (cam_from_model * reconstruction.Point3D(point2D.point3D_id).xyz)
                .z();
        if (depth > 0 && point2D.xy.x() >= 0 && point2D.xy.y() >= 0 &&
            point2D.xy.x() < view.camera->width &&
            point2D.xy.y() < view.camera->height) {
          // (cam_from_common maps to the camera in the model's units.)
          double& cell_depth = view.min_depth[view.Cell(point2D.xy)];
          cell_depth = cell_depth == 0 ? depth : std::min(cell_depth, depth);
        }
      }
    }
    const size_t step = std::max<size_t>(1, point3D_ids.size() / kMaxNumPoints);
    for (size_t i = 0; i < point3D_ids.size(); i += step) {
      view.points.push_back(common_from_model *
                            reconstruction.Point3D(point3D_ids[i]).xyz);
    }
    views.push_back(std::move(view));
  }
  return views;
}

// How many points of `other` `view` sees: in front, inside the image, not
// behind the surfaces it sees there (nor where it sees none), under rays at
// most `max_ray_angle` apart.
int NumVisiblePoints(const ImageView& view,
                     const ImageView& other,
                     const double min_cos_ray_angle) {
  // Depth slack before a point counts as hidden behind a seen surface.
  constexpr double kMaxDepthRatio = 1.25;
  int num_visible = 0;
  for (const Eigen::Vector3d& point : other.points) {
    const Eigen::Vector3d point_in_cam = view.cam_from_common * point;
    if (point_in_cam.z() <= 0) {
      continue;
    }
    const std::optional<Eigen::Vector2d> xy =
        view.camera->ImgFromCam(point_in_cam);
    if (!xy || xy->x() < 0 || xy->y() < 0 || xy->x() >= view.camera->width ||
        xy->y() >= view.camera->height) {
      continue;
    }
    const double surface_depth = view.min_depth[view.Cell(*xy)];
    if (surface_depth == 0 ||
        point_in_cam.z() > kMaxDepthRatio * surface_depth) {
      continue;
    }
    const Eigen::Vector3d ray = (point - view.center).normalized();
    const Eigen::Vector3d other_ray = (point - other.center).normalized();
    if (ray.dot(other_ray) >= min_cos_ray_angle) {
      ++num_visible;
    }
  }
  return num_visible;
}

// The given quantile of the centre distances of the verified pairs among
// `views`; 0 if there are none.
double VerifiedPairDistanceQuantile(
    const std::vector<ImageView>& views,
    const std::function<bool(image_t, image_t)>& is_verified_pair,
    const double quantile) {
  std::vector<double> distances;
  for (size_t i = 0; i < views.size(); ++i) {
    for (size_t j = i + 1; j < views.size(); ++j) {
      if (is_verified_pair(views[i].image_id, views[j].image_id)) {
        distances.push_back((views[i].center - views[j].center).norm());
      }
    }
  }
  if (distances.empty()) {
    return 0;
  }
  const size_t k = std::min(
      distances.size() - 1,
      static_cast<size_t>(std::floor(quantile * (distances.size() - 1))));
  std::nth_element(distances.begin(), distances.begin() + k, distances.end());
  return distances[k];
}

}  // namespace

bool CovisibilityCheckOptions::Check() const {
  CHECK_OPTION_GT(max_ray_angle_deg, 0);
  CHECK_OPTION_LE(max_ray_angle_deg, 180);
  if (!CheckFlag(min_rate_ratio >= 0,
                 "covisibility_min_rate_ratio",
                 min_rate_ratio,
                 "0 or more (0: no check)")) {
    return false;
  }
  CHECK_OPTION_GE(min_num_predicted_pairs, 1);
  return true;
}

CovisibilityCheck CheckCovisibility(
    const Reconstruction& reconstruction1,
    const Reconstruction& reconstruction2,
    const Sim3d& second_from_first,
    const std::function<bool(image_t, image_t)>& is_verified_pair,
    const std::function<bool(image_t, image_t)>& is_compared_pair,
    const CovisibilityCheckOptions& options) {
  THROW_CHECK(options.Check());
  CovisibilityCheck check;
  const std::vector<ImageView> views1 = ImageViews(reconstruction1, Sim3d());
  const std::vector<ImageView> views2 =
      ImageViews(reconstruction2, Inverse(second_from_first));

  // Pairs are tested up to this quantile of the centre distances of the
  // verified pairs inside the models.
  constexpr double kMaxDistanceQuantile = 0.9;
  const double max_distance =
      std::max(VerifiedPairDistanceQuantile(
                   views1, is_verified_pair, kMaxDistanceQuantile),
               VerifiedPairDistanceQuantile(
                   views2, is_verified_pair, kMaxDistanceQuantile));
  if (max_distance <= 0) {
    return check;
  }

  // Counts the pair if the matcher compared it and it is predicted co-visible.
  constexpr int kMinNumPoints = 15;
  const double min_cos = std::cos(DegToRad(options.max_ray_angle_deg));
  const auto count_pair = [&](const ImageView& view1,
                              const ImageView& view2,
                              PairCounts* counts) {
    if ((is_compared_pair &&
         !is_compared_pair(view1.image_id, view2.image_id)) ||
        NumVisiblePoints(view1, view2, min_cos) < kMinNumPoints ||
        NumVisiblePoints(view2, view1, min_cos) < kMinNumPoints) {
      return;
    }
    ++counts->num_predicted;
    counts->num_verified += is_verified_pair(view1.image_id, view2.image_id);
  };

  // Inside each model: at most 2000 of its near pairs (evenly chosen).
  for (const std::vector<ImageView>* views : {&views1, &views2}) {
    std::vector<std::pair<int, int>> near_pairs;
    for (size_t i = 0; i < views->size(); ++i) {
      for (size_t j = i + 1; j < views->size(); ++j) {
        if (((*views)[i].center - (*views)[j].center).norm() <= max_distance) {
          near_pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
        }
      }
    }
    const size_t step = std::max<size_t>(1, near_pairs.size() / 2000);
    for (size_t k = 0; k < near_pairs.size(); k += step) {
      count_pair((*views)[near_pairs[k].first],
                 (*views)[near_pairs[k].second],
                 &check.internal);
    }
  }

  for (const ImageView& view1 : views1) {
    if (HasPosedImage(reconstruction2, view1.image_id)) {
      continue;
    }
    for (const ImageView& view2 : views2) {
      if ((view1.center - view2.center).norm() > max_distance ||
          HasPosedImage(reconstruction1, view2.image_id)) {
        continue;
      }
      count_pair(view1, view2, &check.cross);
    }
  }

  check.consistent =
      check.cross.num_predicted < options.min_num_predicted_pairs ||
      check.cross.Rate() >= options.min_rate_ratio * check.internal.Rate();
  return check;
}

}  // namespace colmap
