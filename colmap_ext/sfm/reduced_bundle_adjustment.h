// Bundle adjustment of a large model on a selected subset of its tracks.
//
// A merged model of many images holds millions of observations, most of
// them redundant for the cameras: after dense matching a point is seen by
// ten or twenty images, and every image observes thousands of points. A
// global bundle adjustment over all of them costs time and memory in
// proportion (Ceres holds a residual block and its Jacobian per
// observation, and the Schur complement grows with the square of the track
// lengths), though a few hundred well-spread points per image fix its pose
// about as well. As in Cui, Shen, Gao and Hu, "Tracks selection for robust,
// efficient and scalable large-scale structure from motion" (Pattern
// Recognition 2017) and Theia's track selection for bundle adjustment, the
// cameras are adjusted on a subset of the tracks chosen per image over an
// image grid,
//
//   min over cameras (poses, intrinsics) and the selected points X_j of
//       sum over the selected points j, images i observing j:
//           rho(|pi(P_i, K_i, X_j) - x_ij|^2),
//
// and every other point is then refined on its own with the cameras fixed,
//
//   min over X_j of sum over i observing j: |pi(P_i, K_i, X_j) - x_ij|^2,
//
// which is independent per point (3 unknowns each) and runs in chunks of
// bounded size. The cameras are noisier than after an adjustment over all
// observations (the noise averages over fewer of them): the merge ends
// with one such adjustment (merged_model_refiner.h).
//
// Both are COLMAP's bundle adjustment (CreateDefaultBundleAdjuster), the
// first with the tracks outside the subset ignored.

#pragma once

#include "colmap/estimators/bundle_adjustment.h"
#include "colmap/estimators/bundle_adjustment_ceres.h"
#include "colmap/scene/reconstruction.h"

#include <string>
#include <unordered_set>

namespace colmap {

struct TrackSelectionOptions {
  // Every image is divided into this many cells along each side. Image by
  // image, every cell that no track selected so far is observed in gets the
  // best track observed there (the longest; among tracks of at least
  // `long_track_length`, the one of smallest mean reprojection error).
  int grid_size = 10;

  // Tracks at least this long count as equally long, so that among long
  // tracks the most accurate ones are chosen.
  int long_track_length = 10;

  // An image observing fewer selected tracks than this gets its next best
  // tracks added (as far as it observes any). The images that observe few
  // of the long tracks are the weakly held ones: 100 (Theia's
  // recommendation) left them noticeably further off than adjustments over
  // all observations, 300 about as close (docs/design.md).
  int min_tracks_per_image = 300;

  bool Check() const;
};

// The tracks (3D point ids) selected in `reconstruction`'s registered
// images as described above.
std::unordered_set<point3D_t> SelectBundleTracks(
    const TrackSelectionOptions& options, const Reconstruction& reconstruction);

// What a bundle adjustment's solve did, for the log: "N iterations, cost
// A -> B, Ts (LINEAR_SOLVER, how it stopped)", where it stopped by its
// convergence tolerances, at its iteration limit (the cost still falling by
// more than the function tolerance: a weakly constrained model may still be
// moving), or otherwise (Ceres' message).
std::string SolverSummaryToString(const ceres::Solver::Options& options,
                                  const ceres::Solver::Summary& summary,
                                  double seconds);

// Adjusts the poses of all registered frames, the intrinsics of their
// cameras and their rigs (as `ba_options` says which to refine) and the
// given points, on the observations of the given points only; the points
// outside `point3D_ids` are left as they are. The gauge is fixed as COLMAP's
// mapper fixes it (BundleAdjustmentGauge::TWO_CAMS_FROM_WORLD: one frame's
// pose, and the coordinate of a second frame's position along which the two
// are furthest apart). The adjustment runs on Ceres with `solver_options` as
// they are (e.g. `ba_options.ceres->solver_options` with a linear solver
// chosen for the size; num_threads -1 takes all cores, whatever the size of
// the problem). Returns whether the solution is usable.
bool AdjustCamerasOnTracks(
    const BundleAdjustmentOptions& ba_options,
    ceres::Solver::Options solver_options,
    const std::unordered_set<point3D_t>& point3D_ids,
    Reconstruction* reconstruction,
    const std::unordered_set<camera_t>& constant_cameras = {},
    const std::unordered_set<rig_t>& constant_rigs = {});

// COLMAP's global bundle adjustment, the counterpart of the above over all
// observations: all registered frames, the intrinsics of their cameras and
// their rigs (as `ba_options` says which to refine) and all points, with
// `ba_options`' loss (`refine_rig_from_world` false holds every pose), the
// gauge fixed as above, solved on Ceres with `solver_options` as they are
// (num_threads -1 takes all cores). In both, the intrinsics of
// `constant_cameras` and the sensor poses of `constant_rigs` are held (as
// IncrementalMapper::Options' constant_cameras and constant_rigs). Returns
// Ceres' summary (with fewer than two registered images or no observation, one
// that is not usable, after no iteration).
ceres::Solver::Summary AdjustAllObservations(
    const BundleAdjustmentOptions& ba_options,
    ceres::Solver::Options solver_options,
    Reconstruction* reconstruction,
    const std::unordered_set<camera_t>& constant_cameras = {},
    const std::unordered_set<rig_t>& constant_rigs = {});

// Refines every point of `reconstruction` outside `excluded_point3D_ids`
// with all cameras and poses fixed (least squares), in problems of at most
// `max_points_per_problem` points. A point that the refinement would put
// behind one of its cameras (nearly parallel rays) keeps its place. Returns
// the number of points refined.
size_t RefinePointsWithFixedCameras(
    const BundleAdjustmentOptions& ba_options,
    const std::unordered_set<point3D_t>& excluded_point3D_ids,
    int max_points_per_problem,
    Reconstruction* reconstruction);

}  // namespace colmap
