// Bundle adjustment with one parameter block per camera pose.
//
// COLMAP's BundleAdjuster solves
//
//   min over poses (q_i, t_i), intrinsics K_c and points X_j of
//       sum over observations x_ij: rho(|pi(K_c(i), q_i X_j + t_i) - x_ij|^2)
//
// with the rotation q_i (a unit quaternion) and the translation t_i of each
// image as two parameter blocks. Ceres eliminates the points first (the
// Schur complement): every point adds an outer product to each cell of the
// reduced camera matrix between two blocks it is observed by, and locks a
// mutex per cell to do so. With two blocks per pose a track of n
// observations touches about (2n)^2 / 2 cells instead of n^2 / 2: on a
// dense scene of long tracks that elimination took more than half of every
// solve (docs/design.md). This adjuster solves the same problem (the
// same cost functions, manifolds, gauge and constant parameters as the
// BundleAdjuster sets them up from a BundleAdjustmentConfig) with each pose
// one block of 7 (quaternion x, y, z, w, then translation; the quaternion's
// manifold times R^3, or a subset of it for constant position
// coordinates), copied out of the reconstruction and back after the solve.
// From the same start it ends at the same cost (to ten digits on the
// models measured), in 0.6-0.8x the time.

#pragma once

#include "colmap/estimators/bundle_adjustment.h"
#include "colmap/scene/reconstruction.h"

#include <array>
#include <memory>
#include <unordered_map>
#include <unordered_set>

#include <ceres/ceres.h>

namespace colmap {

class PoseBlockBundleAdjuster {
 public:
  // `config` names images (and constant poses, positions and intrinsics)
  // only: configured points are not supported.
  PoseBlockBundleAdjuster(const BundleAdjustmentOptions& options,
                          const BundleAdjustmentConfig& config);

  // Adds the observations of the configuration's images, as COLMAP's
  // BundleAdjuster does, or only those of the points in `point3D_ids`.
  // A point observed outside the problem is held, as there.
  void SetUpProblem(Reconstruction* reconstruction,
                    const std::unordered_set<point3D_t>* point3D_ids = nullptr);

  const ceres::Problem& Problem() const;

  // Solves the problem set up before with `solver_options` (num_threads -1
  // takes all cores) and writes the adjusted poses into `reconstruction`.
  ceres::Solver::Summary Solve(ceres::Solver::Options solver_options,
                               Reconstruction* reconstruction);

 private:
  const BundleAdjustmentOptions options_;
  const BundleAdjustmentConfig config_;
  std::unique_ptr<ceres::LossFunction> loss_function_;
  std::unique_ptr<ceres::Problem> problem_;
  std::unordered_map<image_t, std::array<double, 7>> poses_;
};

// The configuration of COLMAP's mapper's global adjustment: every registered
// image of `reconstruction` (at least two), the gauge held by the first
// one's pose and the first coordinate of the second's position.
BundleAdjustmentConfig MappersGauge(const Reconstruction& reconstruction);

// COLMAP's global bundle adjustment (IncrementalMapper::AdjustGlobalBundle)
// solved by the adjuster above, the linear solver and threads chosen as
// COLMAP's BundleAdjuster chooses them. Returns false where there is
// nothing to adjust, as BundleAdjuster::Solve does. The community mapper
// gives it to COLMAP's incremental mapper of every community
// (IncrementalMapper::Options::global_bundle_adjuster, patches/).
bool AdjustGlobalBundleWithPoseBlocks(const BundleAdjustmentOptions& options,
                                      const BundleAdjustmentConfig& config,
                                      Reconstruction* reconstruction);

}  // namespace colmap
