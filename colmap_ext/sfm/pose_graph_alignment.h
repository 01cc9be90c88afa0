// Scale-drift-aware pose graph over the cameras of joined community models.
//
// One similarity per community aligns a community that is rigid; one that
// bent inside itself (a short walkway piece, a chain with per-image focal
// lengths) cannot meet all its neighbours with one similarity, and the
// final bundle adjustment, started from the bent shape, stays in its basin.
// Measured on a generated open chain of 500 images: bundle adjustment of the
// same correspondences from the ground-truth poses reached a median camera
// error of 0.15 m, from the joined communities' poses 0.28 m.
//
// As the loop closure of Strasdat et al. (Scale Drift-Aware Large Scale
// Monocular SLAM, RSS 2010) and ORB-SLAM's essential graph, every camera of
// every community model becomes a vertex, a similarity world_from_cam_i =
// (e^{s_i}, R_i^T, c_i), and every model contributes, between pairs of its
// images that observe many common points, the relative pose it estimated,
// cam_i_from_cam_j = (R_ij, t_ij), with relative scale 1. An image that
// several models hold (the images a community borrows from its neighbours)
// is one vertex per model, tied together by equal rotation and centre and
// a free scale (its models' scales differ there). The graph minimises
//
//   sum over a model's edges (i,j):
//       |Log(R_i R_j^T R_ij^T)|^2
//     + |(e^{-s_i} R_i (c_j - c_i) - t_ij) / d_K|^2 + (s_j - s_i)^2
//   + sum over the vertices i, i' of one image:
//       |Log(R_i R_i'^T)|^2 + |(c_i - c_i') / d_K|^2,
//
// from the models' poses in the world frame (as the similarity averaging
// placed them), d_K being the median length of the model's edges (so that
// every term is relative and models of any scale weigh alike). Where a
// community's two ends disagree with its neighbours, the graph spreads the
// disagreement over the community's many edges, as loop closure spreads
// drift, instead of leaving it at one border; a community consistent with
// its neighbours keeps its shape (all residuals vanish at the start). Each
// image of the merged model takes the pose of its owning model's vertex,
// and each 3D point moves with the vertex of its first observation, so that
// points and cameras stay consistent for the bundle adjustment that
// follows.

#pragma once

#include "colmap/geometry/rigid3.h"
#include "colmap/scene/reconstruction.h"

#include <unordered_set>
#include <vector>

namespace colmap {

struct PoseGraphAlignmentOptions {
  // An edge links two images of a community model that observe at least
  // this many common 3D points ...
  int min_num_shared_points = 20;
  // ... and is among the strongest of one of them (by common points).
  int max_num_neighbors = 8;

  // The vertices of one image are tied only if their models placed it
  // within this rotation (degrees) and distance (in edge lengths d_K) of
  // each other: a community that registered a borrowed image on a repeated
  // structure must not drag its neighbour. Measured on a generated loop
  // with identical towers: without this gate, one such image moved whole
  // communities away.
  double max_tie_rotation_deg = 10.0;
  double max_tie_distance = 3.0;

  // Levenberg-Marquardt iterations.
  int max_num_iterations = 100;

  bool Check() const;
};

// A relative pose estimated by one community model.
struct PoseGraphEdge {
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  // cam1_from_cam2, in the community model's frame.
  Rigid3d cam1_from_cam2;
  // The length scale of the model's edges (median |t|), as d_K above.
  double length_scale = 1.0;
  // (The edges weigh alike. Weighting them by the points the two images
  // share, so that well-observed pairs hold more, made a generated open
  // chain worse: 0.29 m median camera error instead of 0.21.)
};

// The covisibility edges of one (community) model, as the options select.
std::vector<PoseGraphEdge> CovisibilityEdges(
    const Reconstruction& reconstruction,
    const PoseGraphAlignmentOptions& options);

struct PoseGraphAlignmentSummary {
  int num_images = 0;
  int num_edges = 0;
  // Ties between the vertices of one image: kept, dropped by the gate, and
  // the largest disagreement among those kept (degrees, edge lengths).
  int num_ties = 0;
  int num_dropped_ties = 0;
  double max_tie_rotation_deg = 0.0;
  double max_tie_distance = 0.0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  // Median and largest movement of the camera centres, relative to the
  // median edge length.
  double median_relative_movement = 0.0;
  double max_relative_movement = 0.0;
};

// Aligns `merged` (the join of `models` in the world frame, each image from
// the model in `owned_image_ids`) by the pose graph of the models, keeping
// the largest model's first image fixed (the gauge).
PoseGraphAlignmentSummary AlignPoseGraph(
    const std::vector<const Reconstruction*>& models,
    const std::vector<std::unordered_set<image_t>>& owned_image_ids,
    const PoseGraphAlignmentOptions& options,
    Reconstruction* merged);

}  // namespace colmap
