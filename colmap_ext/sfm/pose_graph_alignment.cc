#include "colmap_ext/sfm/pose_graph_alignment.h"

#include "colmap/estimators/cost_functions.h"
#include "colmap/math/math.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <set>
#include <unordered_map>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace colmap {
namespace {

// The residual of one edge (see the header): rotation (3, radians),
// relative position (3, in units of the community's edge length), log scale
// (1). Parameters per camera: cam_from_world rotation (Eigen quaternion,
// x y z w), centre in the world, log scale.
class Sim3EdgeCostFunction {
 public:
  Sim3EdgeCostFunction(const Rigid3d& cam1_from_cam2, double length_scale)
      : cam1_from_cam2_(cam1_from_cam2),
        inv_length_scale_(1.0 / length_scale) {}

  static ceres::CostFunction* Create(const Rigid3d& cam1_from_cam2,
                                     double length_scale) {
    return new ceres::
        AutoDiffCostFunction<Sim3EdgeCostFunction, 7, 4, 3, 1, 4, 3, 1>(
            new Sim3EdgeCostFunction(cam1_from_cam2, length_scale));
  }

  template <typename T>
  bool operator()(const T* const quat1,
                  const T* const center1,
                  const T* const log_scale1,
                  const T* const quat2,
                  const T* const center2,
                  const T* const log_scale2,
                  T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> cam1_from_world(quat1);
    const Eigen::Map<const Eigen::Quaternion<T>> cam2_from_world(quat2);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> c1(center1);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> c2(center2);

    const Eigen::Quaternion<T> error =
        cam1_from_world * cam2_from_world.conjugate() *
        cam1_from_cam2_.rotation.conjugate().cast<T>();
    const T error_wxyz[4] = {error.w(), error.x(), error.y(), error.z()};
    ceres::QuaternionToAngleAxis(error_wxyz, residuals);

    const Eigen::Matrix<T, 3, 1> position2_in_cam1 =
        ceres::exp(-log_scale1[0]) * (cam1_from_world * (c2 - c1));
    for (int k = 0; k < 3; ++k) {
      residuals[3 + k] =
          (position2_in_cam1[k] - T(cam1_from_cam2_.translation[k])) *
          T(inv_length_scale_);
    }
    residuals[6] = log_scale2[0] - log_scale1[0];
    return true;
  }

 private:
  const Rigid3d cam1_from_cam2_;
  const double inv_length_scale_;
};

// Two vertices of one image (held by two models): the same rotation and
// centre (6 residuals, the centre in units of the edge length); their
// scales are free.
class SameImageCostFunction {
 public:
  explicit SameImageCostFunction(double length_scale)
      : inv_length_scale_(1.0 / length_scale) {}

  static ceres::CostFunction* Create(double length_scale) {
    return new ceres::
        AutoDiffCostFunction<SameImageCostFunction, 6, 4, 3, 4, 3>(
            new SameImageCostFunction(length_scale));
  }

  template <typename T>
  bool operator()(const T* const quat1,
                  const T* const center1,
                  const T* const quat2,
                  const T* const center2,
                  T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> cam_from_world1(quat1);
    const Eigen::Map<const Eigen::Quaternion<T>> cam_from_world2(quat2);
    const Eigen::Quaternion<T> error =
        cam_from_world1 * cam_from_world2.conjugate();
    const T error_wxyz[4] = {error.w(), error.x(), error.y(), error.z()};
    ceres::QuaternionToAngleAxis(error_wxyz, residuals);
    for (int k = 0; k < 3; ++k) {
      residuals[3 + k] = (center1[k] - center2[k]) * T(inv_length_scale_);
    }
    return true;
  }

 private:
  const double inv_length_scale_;
};

struct CameraVertex {
  Eigen::Quaterniond cam_from_world;
  Eigen::Vector3d center;
  double log_scale = 0.0;
};

}  // namespace

bool PoseGraphAlignmentOptions::Check() const {
  CHECK_OPTION_GT(min_num_shared_points, 0);
  CHECK_OPTION_GT(max_num_neighbors, 0);
  CHECK_OPTION_GT(max_num_iterations, 0);
  CHECK_OPTION_GT(max_tie_rotation_deg, 0);
  CHECK_OPTION_GT(max_tie_distance, 0);
  return true;
}

std::vector<PoseGraphEdge> CovisibilityEdges(
    const Reconstruction& reconstruction,
    const PoseGraphAlignmentOptions& options) {
  THROW_CHECK(options.Check());
  const std::vector<image_t>& image_ids = reconstruction.RegImageIds();
  std::unordered_map<image_t, size_t> index_of_image;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    index_of_image.emplace(image_ids[i], i);
  }

  // Per image, the images it shares the most points with.
  std::set<std::pair<size_t, size_t>> pairs;
  std::vector<int> num_shared(image_ids.size(), 0);
  std::vector<size_t> touched;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    for (const Point2D& point2D :
         reconstruction.Image(image_ids[i]).Points2D()) {
      if (!point2D.HasPoint3D()) {
        continue;
      }
      for (const TrackElement& track_el :
           reconstruction.Point3D(point2D.point3D_id).track.Elements()) {
        const auto it = index_of_image.find(track_el.image_id);
        if (it == index_of_image.end() || it->second == i) {
          continue;
        }
        if (num_shared[it->second]++ == 0) {
          touched.push_back(it->second);
        }
      }
    }
    std::vector<std::pair<int, size_t>> neighbors;
    for (const size_t j : touched) {
      if (num_shared[j] >= options.min_num_shared_points) {
        neighbors.emplace_back(num_shared[j], j);
      }
      num_shared[j] = 0;
    }
    touched.clear();
    const size_t num_kept =
        std::min<size_t>(neighbors.size(), options.max_num_neighbors);
    std::partial_sort(neighbors.begin(),
                      neighbors.begin() + num_kept,
                      neighbors.end(),
                      std::greater<std::pair<int, size_t>>());
    for (size_t k = 0; k < num_kept; ++k) {
      pairs.emplace(std::min(i, neighbors[k].second),
                    std::max(i, neighbors[k].second));
    }
  }

  std::vector<PoseGraphEdge> edges;
  edges.reserve(pairs.size());
  std::vector<double> lengths;
  lengths.reserve(pairs.size());
  for (const auto& pair : pairs) {
    PoseGraphEdge edge;
    edge.image_id1 = image_ids[pair.first];
    edge.image_id2 = image_ids[pair.second];
    edge.cam1_from_cam2 =
        reconstruction.Image(edge.image_id1).CamFromWorld() *
        Inverse(reconstruction.Image(edge.image_id2).CamFromWorld());
    lengths.push_back(edge.cam1_from_cam2.translation.norm());
    edges.push_back(edge);
  }
  if (!lengths.empty()) {
    std::nth_element(
        lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
    const double length_scale = std::max(lengths[lengths.size() / 2], 1e-12);
    for (PoseGraphEdge& edge : edges) {
      edge.length_scale = length_scale;
    }
  }
  return edges;
}

PoseGraphAlignmentSummary AlignPoseGraph(
    const std::vector<const Reconstruction*>& models,
    const std::vector<std::unordered_set<image_t>>& owned_image_ids,
    const PoseGraphAlignmentOptions& options,
    Reconstruction* merged) {
  THROW_CHECK(options.Check());
  THROW_CHECK_NOTNULL(merged);
  THROW_CHECK_EQ(models.size(), owned_image_ids.size());
  PoseGraphAlignmentSummary summary;

  // The vertices: every registered image of every model, as it placed it.
  std::vector<CameraVertex> vertices;
  std::vector<std::unordered_map<image_t, size_t>> vertex_of_image(
      models.size());
  std::unordered_map<image_t, std::vector<size_t>> vertices_of_image;
  std::unordered_map<image_t, size_t> owner_vertex;
  for (size_t m = 0; m < models.size(); ++m) {
    for (const image_t image_id : models[m]->RegImageIds()) {
      if (!merged->ExistsImage(image_id) ||
          !merged->IsImageRegistered(image_id)) {
        continue;
      }
      const Image& image = models[m]->Image(image_id);
      CameraVertex vertex;
      vertex.cam_from_world = image.CamFromWorld().rotation;
      vertex.center = image.ProjectionCenter();
      vertex_of_image[m].emplace(image_id, vertices.size());
      vertices_of_image[image_id].push_back(vertices.size());
      if (owned_image_ids[m].count(image_id)) {
        owner_vertex.emplace(image_id, vertices.size());
      }
      vertices.push_back(vertex);
    }
  }

  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::vector<double> model_length_scale(models.size(), 0.0);
  std::vector<double> lengths;
  size_t largest_model = 0;
  for (size_t m = 0; m < models.size(); ++m) {
    if (vertex_of_image[m].size() > vertex_of_image[largest_model].size()) {
      largest_model = m;
    }
    for (const PoseGraphEdge& edge : CovisibilityEdges(*models[m], options)) {
      const auto it1 = vertex_of_image[m].find(edge.image_id1);
      const auto it2 = vertex_of_image[m].find(edge.image_id2);
      if (it1 == vertex_of_image[m].end() || it2 == vertex_of_image[m].end()) {
        continue;
      }
      CameraVertex& vertex1 = vertices[it1->second];
      CameraVertex& vertex2 = vertices[it2->second];
      problem.AddResidualBlock(
          Sim3EdgeCostFunction::Create(edge.cam1_from_cam2, edge.length_scale),
          nullptr,
          vertex1.cam_from_world.coeffs().data(),
          vertex1.center.data(),
          &vertex1.log_scale,
          vertex2.cam_from_world.coeffs().data(),
          vertex2.center.data(),
          &vertex2.log_scale);
      model_length_scale[m] = edge.length_scale;
      lengths.push_back(edge.length_scale);
      ++summary.num_edges;
    }
  }
  if (summary.num_edges == 0) {
    return summary;
  }
  // The vertices of one image, tied to its owner's.
  for (size_t m = 0; m < models.size(); ++m) {
    for (const auto& image_and_vertex : vertex_of_image[m]) {
      const auto owner = owner_vertex.find(image_and_vertex.first);
      if (owner == owner_vertex.end() ||
          owner->second == image_and_vertex.second ||
          !problem.HasParameterBlock(&vertices[owner->second].log_scale) ||
          !problem.HasParameterBlock(
              &vertices[image_and_vertex.second].log_scale)) {
        continue;
      }
      CameraVertex& vertex1 = vertices[owner->second];
      CameraVertex& vertex2 = vertices[image_and_vertex.second];
      // A model that placed the image far from where its owner did (e.g.
      // registered it on a repeated structure) does not tie it.
      const double rotation_deg = RadToDeg(
          vertex1.cam_from_world.angularDistance(vertex2.cam_from_world));
      const double distance =
          (vertex1.center - vertex2.center).norm() / model_length_scale[m];
      if (rotation_deg > options.max_tie_rotation_deg ||
          distance > options.max_tie_distance) {
        ++summary.num_dropped_ties;
        continue;
      }
      summary.max_tie_rotation_deg =
          std::max(summary.max_tie_rotation_deg, rotation_deg);
      summary.max_tie_distance = std::max(summary.max_tie_distance, distance);
      ++summary.num_ties;
      problem.AddResidualBlock(
          SameImageCostFunction::Create(model_length_scale[m]),
          nullptr,
          vertex1.cam_from_world.coeffs().data(),
          vertex1.center.data(),
          vertex2.cam_from_world.coeffs().data(),
          vertex2.center.data());
      ++summary.num_edges;
    }
  }
  // The gauge: the largest model's first own image in the graph.
  CameraVertex* fixed = nullptr;
  for (const image_t image_id : models[largest_model]->RegImageIds()) {
    const auto it = owner_vertex.find(image_id);
    if (it != owner_vertex.end() &&
        vertex_of_image[largest_model].count(image_id) &&
        problem.HasParameterBlock(&vertices[it->second].log_scale)) {
      fixed = &vertices[it->second];
      break;
    }
  }
  if (fixed == nullptr) {
    return summary;
  }
  for (CameraVertex& vertex : vertices) {
    if (problem.HasParameterBlock(&vertex.log_scale)) {
      SetQuaternionManifold(&problem, vertex.cam_from_world.coeffs().data());
      ++summary.num_images;
    }
  }
  problem.SetParameterBlockConstant(fixed->cam_from_world.coeffs().data());
  problem.SetParameterBlockConstant(fixed->center.data());
  problem.SetParameterBlockConstant(&fixed->log_scale);

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary solver_summary;
  ceres::Solve(solver_options, &problem, &solver_summary);
  summary.initial_cost = solver_summary.initial_cost;
  summary.final_cost = solver_summary.final_cost;
  if (!solver_summary.IsSolutionUsable()) {
    LOG(WARNING) << "The pose graph was not solved: "
                 << solver_summary.BriefReport();
    return summary;
  }

  // world_new_from_world, per image of `merged` (its owner's vertex): a
  // point seen by the camera keeps its place in the camera's scaled frame.
  std::unordered_map<image_t, Sim3d> corrections;
  std::vector<double> movements;
  for (const auto& image_and_vertex : owner_vertex) {
    const CameraVertex& vertex = vertices[image_and_vertex.second];
    if (!problem.HasParameterBlock(&vertex.log_scale)) {
      continue;
    }
    Image& image = merged->Image(image_and_vertex.first);
    const Eigen::Quaterniond cam_from_world =
        vertex.cam_from_world.normalized();
    const Rigid3d& old_cam_from_world = image.CamFromWorld();
    const Sim3d world_new_from_cam(
        std::exp(vertex.log_scale), cam_from_world.conjugate(), vertex.center);
    const Sim3d cam_from_world_old(
        1.0, old_cam_from_world.rotation, old_cam_from_world.translation);
    corrections.emplace(image_and_vertex.first,
                        world_new_from_cam * cam_from_world_old);
    movements.push_back((vertex.center - image.ProjectionCenter()).norm());
    image.CamFromWorld() =
        Rigid3d(cam_from_world, -(cam_from_world * vertex.center));
  }
  for (const point3D_t point3D_id : merged->Point3DIds()) {
    Point3D& point3D = merged->Point3D(point3D_id);
    if (point3D.track.Length() == 0) {
      continue;
    }
    const auto it = corrections.find(point3D.track.Element(0).image_id);
    if (it != corrections.end()) {
      point3D.xyz = it->second * point3D.xyz;
    }
  }

  if (!movements.empty()) {
    std::sort(lengths.begin(), lengths.end());
    const double median_length = lengths[lengths.size() / 2];
    std::sort(movements.begin(), movements.end());
    summary.median_relative_movement =
        movements[movements.size() / 2] / median_length;
    summary.max_relative_movement = movements.back() / median_length;
  }
  return summary;
}

}  // namespace colmap
