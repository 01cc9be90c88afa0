// Robust rotation averaging: L1RA followed by IRLS.
//
// Chatterjee and Govindu, "Efficient and Robust Large-Scale Rotation
// Averaging", ICCV 2013. Given relative rotations R_ij ~ R_j R_i^T on the
// edges of a connected graph, find absolute rotations R_i (R_ref fixed) that
// minimise the robust sum over edges of d(R_ij, R_j R_i^T).
//
//   1. Initialise R_i by chaining the relative rotations along a maximum
//      spanning tree (edge weights c_ij: confidence).
//   2. L1RA: with dR_ij = R_j^T R_ij R_i and w_ij = log(dR_ij) (angle-axis),
//      solve  min_x sum_ij c_ij |x_j - x_i - w_ij|_1  (x_ref = 0; per axis,
//      by COLMAP's ADMM least absolute deviations solver) and update
//      R_k <- R_k exp(x_k), until the update is negligible.
//   3. IRLS: the same linearisation in weighted least squares, with weights
//      c_ij phi(r), phi(r) = sigma^2 / (r^2 + sigma^2)^2 the Geman-McClure
//      weight of each edge's residual angle r, refining what L1 found.
// COLMAP's RotationEstimator solves the same over the images of a
// Reconstruction, every pair alike; the merge's links need their own
// confidences, so that a cycle's gap falls on its weakest link.

#pragma once

#include "colmap/util/eigen_alignment.h"

#include <vector>

#include <Eigen/Geometry>

namespace colmap {

struct RelativeRotation {
  int node1 = -1;
  int node2 = -1;
  // node2_from_node1: R_node2 ~ rotation * R_node1.
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  // Confidence (larger is better): the spanning tree follows the most
  // confident edges, and every edge's residual counts this many times in
  // L1RA and IRLS, so that on a cycle that does not close the least
  // confident edges take up the disagreement.
  double weight = 1.0;
};

// Estimates R_0..R_{num_nodes-1} with R_reference = Identity. The graph must
// be connected. Returns false if it is not or if a solver fails. L1RA stops
// after 30 iterations or an update below 1e-9 rad, IRLS (Geman-McClure
// sigma 5 degrees) after 50 or below 1e-12 rad.
bool AverageRotations(int num_nodes,
                      const std::vector<RelativeRotation>& relative_rotations,
                      int reference_node,
                      std::vector<Eigen::Quaterniond>* rotations);

}  // namespace colmap
