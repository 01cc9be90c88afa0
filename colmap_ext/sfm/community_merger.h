// Merging community reconstructions into one model.
//
// CSfM (Cui et al., ICIP 2017), section 3.4: given the similarity
// world_from_community of every community (similarity_averaging.h), its
// cameras and points are transformed into the global frame,
//     X_g = s_i R_i X + T_i,  R_g = R R_i^T,  C_g = s_i R_i C + T_i,
// and joined; a final bundle adjustment refines all cameras and points.
//
// Here the join keeps every community's tracks, then merges the 3D points
// that the pairwise similarities found to correspond (their inliers), so
// that the bundle adjustment couples the communities. The refinement runs
// COLMAP's IncrementalMapper on the full database: it registers images
// their communities left out, where the merged model now sees enough of
// their points, completes and merges tracks over the whole correspondence
// graph, re-triangulates, and alternates global bundle adjustment (Ceres,
// SuiteSparse) with outlier filtering, as the incremental mapper's own
// global refinement does.

#pragma once

#include "colmap_ext/sfm/block_registration.h"
#include "colmap_ext/sfm/reduced_bundle_adjustment.h"

#include "colmap/controllers/incremental_mapper.h"
#include "colmap/geometry/sim3.h"
#include "colmap/scene/database_cache.h"
#include "colmap/scene/reconstruction.h"

#include <functional>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace colmap {

// Transforms every reconstruction into the global frame and joins their
// cameras, images and points into `merged` (which must be empty). Each image
// is taken from the one reconstruction that owns it (`owned_image_ids`; an
// image registered by several, as on community borders, is owned by one);
// the other reconstructions' observations in it are dropped, and points left
// without observations too. A camera used by several reconstructions takes
// the parameters of the one owning the most images with it. `point3D_ids`
// receives, per reconstruction, the new id of each of its points that was
// kept. The reconstructions are transformed in place.
void JoinReconstructions(
    const std::vector<Reconstruction*>& reconstructions,
    const std::vector<Sim3d>& world_from_reconstruction,
    const std::vector<std::unordered_set<image_t>>& owned_image_ids,
    Reconstruction* merged,
    std::vector<std::unordered_map<point3D_t, point3D_t>>* point3D_ids);

// Merges pairs of corresponding 3D points (ids of `reconstruction`) into
// single tracks. A pair is skipped if one of its points was merged already
// or if both are observed in a common image. Afterwards, points observed
// fewer than twice are deleted. Returns the number of merges.
size_t MergeCorrespondingPoints(
    const std::vector<std::pair<point3D_t, point3D_t>>& point3D_pairs,
    Reconstruction* reconstruction);

// The reconstruction without the registered images outside `image_ids`
// (e.g. a community model without the images it borrowed from its
// neighbours), their observations, and the points left with fewer than two
// observations. Returns `reconstruction` itself if all its registered images
// are in `image_ids`, a new reconstruction otherwise.
std::shared_ptr<Reconstruction> RestrictToImages(
    const std::unordered_set<image_t>& image_ids,
    std::shared_ptr<Reconstruction> reconstruction);

struct MergedModelRefinementOptions {
  // Try to register the images that no community registered: after the
  // alignment, again after the triangulation anew and after every
  // adjustment (each image at most Mapper.max_reg_trials times per loading
  // of the correspondences or block registration); a round that registered
  // images is followed by another.
  bool register_remaining_images = true;

  // Models of communities whose images are offered to this refinement
  // (parts that no kept similarity joins to this one, communities that left
  // the merge without being broken) are registered as one block each,
  // through the images the merged model registers in common with them
  // (block_registration.h), instead of image by image; their images the
  // block does not hold are still registered one by one. Part of the
  // registration above: off with it. On South Building (stop 29's
  // database: a community of 24 images whose links were all dropped) 3
  // images one by one and 21 as a block took 1.2 s instead of 12.5 s.
  bool register_offered_blocks = true;
  BlockRegistrationOptions block_registration;

  // The refinement has three steps. (1) Alignment, before the
  // correspondences are loaded: a bundle adjustment of all cameras on a
  // reduced set of the joined points (those seen from two communities and,
  // per image, at most this many with the longest tracks), intrinsics
  // fixed, under a robust (soft L1) loss if
  // `robust_first_adjustment`: the communities' own drift leaves the merged
  // points a few pixels apart at first, and the robust loss lets them pull
  // the communities together where least squares would be dragged by the
  // few wrong merges. (2) All points are deleted and every image is
  // triangulated anew over the full correspondence graph, as the
  // incremental mapper's tracks are built (the communities' tracks end at
  // their borders, and their merge leaves some points split in two): on a
  // generated loop of 420 images that took the median camera error from
  // 0.0204 to 0.0175 (colmap mapper: 0.0164), on an open chain of 500
  // images with a camera per image from 0.38 to 0.16. The new observations
  // above the mapper's reprojection error are then filtered (the
  // triangulator admits them by angle). (3) Least squares
  // bundle adjustments alternate with filtering, as in the incremental
  // mapper's global refinement (pairs left under-reconstructed are
  // triangulated again after the first), until fewer than
  // `max_refinement_change` of the observations change.
  //
  // The refinement ends close to where step (1) leaves it (its adjustments
  // converge in 2-6 iterations each), so this cap moves the result within
  // what the data cannot tell apart. Merge stage reruns on the same
  // communities (stop 40), median camera error with 200 / all points (2000
  // already takes all): South Building, five seeds, 0.0121-0.0125 /
  // 0.0119-0.0121 (colmap mapper 0.0116-0.0122); generated open chains of
  // 500 images with a camera per image, seeds 3 / 5 / 6: 0.149 / 0.126,
  // 0.289 / 0.301 (one image fewer registered), 0.511 / 0.525; courtyard
  // loop 0.0157 / 0.0160; dense scene 0.0037 / 0.0036 (90th percentile
  // 0.0086 / 0.0089). No value wins on every scene, and all points cost
  // time: the merge's refinement took 14 / 18 s on South Building, 18 / 31 s
  // on the chain of seed 3, 63 / 65 s on the dense scene.
  int alignment_max_points_per_image = 200;
  bool robust_first_adjustment = true;
  // The observations of the points triangulated anew in step (2) are
  // filtered at this multiple of --Mapper.filter_max_reproj_error before
  // the first adjustment of step (3); 0: not filtered before it. Merge
  // stage reruns, median / 90th-percentile camera error for 1 / 2 / 0:
  // generated loop of 1002 images 0.054 / 0.080, 0.057 / 0.092, 0.061 /
  // 0.112; open chain of 500 images with a camera per image 0.245 / 0.61,
  // 0.29 / 0.81, 0.153 / 0.60 (its weakly constrained drift ends where the
  // start leaves it: every variant ends at the same cost).
  double triangulation_filter_factor = 1.0;

  // Before the last adjustment (after step (3)) and after it, observations
  // whose reprojection error exceeds this multiple of the model's
  // reprojection noise sigma (reprojection_noise.h) are filtered, where that
  // is below --Mapper.filter_max_reproj_error, and never below a pixel; 0:
  // that fixed threshold alone. Under Gaussian keypoint noise an error
  // beyond 4 sigma has probability exp(-8) = 3e-4: what lies between there
  // and the mapper's 4 px is wrong matches, which the joined tracks (all
  // triangulated at once, then completed and merged) hold more of than the
  // incremental mapper's. On a generated dense scene of 560 images, 0.11%
  // of our observations were beyond 3 px against the mapper's 0.02%, and
  // the adjustment of our observations started from the ground truth ended
  // on our model (the error was in the observations, not the optimisation).
  // Real photographs at 1024 px (sigma 0.15-0.2 px, a heavy tail: 5% of
  // South Building's observations beyond 6 sigma) are held at the pixel,
  // about 5-6 sigma. Merge stage reruns on the same communities (stop 41),
  // median camera error for multiples 8 / 4: generated dense scenes 0.00375
  // / 0.00335 and 0.00369 / 0.00356 (colmap mapper 0.0034, 0.0038; 90th
  // percentile 0.0092 / 0.0083, 0.0086 / 0.0077), courtyard loops 0.0157 /
  // 0.0146, 0.0204 / 0.0201, 0.0147 / 0.0144, 0.0110 / 0.0116 (mapper
  // 0.0164, 0.0210, 0.0227, 0.0112); open chains with a noise of 1 px (so
  // about 4 px either way) within 1.5%; South Building over five seeds
  // 0.0121-0.0125 / 0.0123-0.0124 and its ten random subsets from 10%
  // closer to 8% further (the mean of the log ratios 0.6% closer); South
  // Building matched only within 5, 10 or 20 images of each other (real
  // open sequences) 0.00193 / 0.00196, 0.00241 / 0.00186, 0.00448 / 0.00351
  // (mapper 0.0028, 0.0037, 0.0070). Multiples 0 / 6 / 8 / 10 on real
  // photographs: README "Stop 37".
  double final_filter_noise_multiple = 4;

  // Step (3) stops once fewer than this fraction of the observations
  // changed in a round; -1: --Mapper.ba_global_max_refinement_change
  // (0.0005). The last adjustment after the rounds takes the last changes
  // in: on a generated dense scene of 560 images (merge stage rerun) the
  // rounds changing 0.11%, 0.08% and 0.05% of the observations left the
  // median / 90th-percentile camera error at 0.00361 / 0.00849 without them
  // (0.00362 / 0.00850 with them), three adjustments of 15-18 s saved.
  double max_refinement_change = 0.002;

  // Every bundle adjustment of step (3) runs with the correspondence graph
  // released; it is loaded again from the database for the track
  // completion after it. The peak then holds the larger of the two, not
  // both, for one more database load and mapper start per round (about 3 s
  // on a generated loop of 1002 images, 10 s on a dense scene of 560, 40 s
  // on 2940 images). Merge stage reruns on the same communities, peak memory
  // held / reloaded, with the alignment of step (1) before the first load:
  // that loop 775 / 568 MB, a dense scene of 560 images 977 (alignment
  // after the load) / 669 MB, an open chain of 500 images 393 / 306 MB, at
  // the same camera error. Without it, the correspondences are held
  // through the rounds, as in the incremental mapper.
  bool reload_correspondences = true;

  // Use Ceres' sparse direct Schur solver at any size. Without it, the
  // solver is chosen as COLMAP's BundleAdjuster chooses it: the iterative
  // Schur solver above 1000 images, whose memory grows with the problem
  // alone (a direct solver's factorization grows faster), but whose inexact
  // steps follow the weakly constrained directions of a long open scene
  // poorly. Merge stage reruns on the same communities, sparse direct /
  // iterative: a generated loop of 1002 images, peak memory 579 / 506 MB
  // (colmap mapper: 748 MB), refinement 58 / 113 s, median /
  // 90th-percentile camera error 0.054 / 0.080 and 0.047 / 0.077; an open
  // chain of 10 landmark clusters, 2940 images, peak 2391 / 2441 MB (both
  // at the correspondence load), refinement 410 / 560 s, error 0.181 /
  // 0.427 and 0.343 / 0.869 at the same final cost.
  bool sparse_solver = true;

  // Ceres' dense Schur solver for an adjustment of at most 1000 images
  // whose reduced camera matrix is dense: where at least this fraction of
  // the pairs of images see a common point (CameraCovisibilityDensity). Above
  // 1 (the default): never. While the adjustments gave each pose two blocks
  // (rotation, translation) it paid: a generated dense scene of 560 images
  // (density 26%), the four adjustments 42 s dense against 51 s sparse.
  // With a block per pose (pose_block_bundle_adjustment.h) the sparse solver's
  // per-cell work shrank fourfold and it overtook the dense one: merge stage
  // reruns on the same communities, sparse / dense, the dense scene 52.8 /
  // 59.6 s, South Building (41%) 11.0-12.4 / 11.5-12.2 s, an open chain of
  // 500 images (11%) 14.1 / 14.6 s, the same models to the sixth digit.
  double dense_solver_min_density = 2;

  // The bundle adjustments of step (3) adjust the cameras on a subset of
  // the tracks, selected per image over a grid (long, accurate tracks
  // spread over every image), and then refine the other points with the
  // cameras fixed, in problems of at most `max_points_per_problem` points
  // (reduced_bundle_adjustment.h). The last adjustment is over all
  // observations, once the correspondences are released: a subset leaves
  // every camera noisier (the noise averages over fewer observations).
  // Measured with the subset forced (`max_selected_observation_fraction`
  // 1) on a generated dense scene of 560 images (merge stage rerun on the
  // same communities): peak memory 805 MB instead of 995 MB, the refinement
  // 176 s instead of 196 s, median / 90th-percentile camera error 0.0039 /
  // 0.0123 against 0.0040 / 0.0120. Without it, every adjustment is over
  // all observations, with the correspondences held.
  bool reduced_adjustment = true;
  // ... where the selected tracks hold at most this fraction of the
  // observations; where they hold more (a sparse scene: few points per
  // grid cell), the round is over all observations, as it saves little.
  // Forced on scenes where they hold more: the dense scene above (69%) was
  // on par; a generated courtyard loop of 420 images (81%) gave a median
  // camera error of 0.0236 against 0.0190 over all, a generated loop of
  // 1002 images (78%) 0.073 against 0.061. So by default no benchmark
  // scene uses it.
  double max_selected_observation_fraction = 0.5;
  TrackSelectionOptions track_selection;
  int max_points_per_problem = 50000;

  // The bundle adjustments stop once an iteration lowers the cost by less
  // than this fraction. The joined communities are each optimal already, so
  // the merged model converges in a few iterations; COLMAP's default (0:
  // run to --Mapper.ba_global_max_num_iterations) spends most of its time
  // on changes below a millionth of the cost. Measured on a generated scene
  // of 1000 images (with the trust region radius below): 1e-6 takes 35 s
  // instead of 157 s for a median camera error 9% larger, 1e-7 takes 45 s
  // for the same error as 0.
  double function_tolerance = 1e-6;

  // Initial Levenberg-Marquardt trust region radius of the bundle
  // adjustments. Ceres starts at 1e4 and spends the first iterations
  // growing it; the joined model is close to the optimum, where full
  // Gauss-Newton steps are right from the start.
  double initial_trust_region_radius = 1e8;

  bool Check() const;
};

// The fraction of the pairs of registered images that see a common 3D point:
// the density of the reduced camera matrix that the Schur complement of a
// bundle adjustment over all points builds (1 with fewer than two images).
double CameraCovisibilityDensity(const Reconstruction& reconstruction);

struct MergedModelRefinementSummary {
  // Images no community of the model had registered, registered by the
  // refinement.
  int num_newly_registered_images = 0;
  // Of those, registered as blocks of offered community models.
  int num_block_registered_images = 0;
  // Images the refinement deregistered as misplaced (they observe few of
  // their visible points) and registered again.
  int num_reregistered_images = 0;
  int num_filtered_images = 0;
  double initial_mean_reprojection_error = 0.0;
  double final_mean_reprojection_error = 0.0;
};

// Completes, merges and refines the joined model with COLMAP's incremental
// mapper machinery on the full database (see the top of this file). The
// mapper, triangulation and global bundle adjustment options come from
// `mapper_options` (the user's --Mapper.* flags). `community_of_image` tells
// the community of each joined image (images it does not list count as a
// community of their own). `load_correspondences` returns the database
// cache of the model's images; it is called after the alignment and, with
// `reload_correspondences`, again after every adjustment round; the cache
// is released before the last adjustment. `offered_models` are the models
// (each in its own frame) of communities whose images are offered to the
// refinement, registered as blocks with `register_offered_blocks`.
MergedModelRefinementSummary RefineMergedModel(
    const MergedModelRefinementOptions& options,
    const IncrementalMapperOptions& mapper_options,
    const std::function<std::shared_ptr<const DatabaseCache>()>&
        load_correspondences,
    const std::unordered_map<image_t, int>& community_of_image,
    const std::vector<std::shared_ptr<const Reconstruction>>& offered_models,
    std::shared_ptr<Reconstruction> reconstruction);

}  // namespace colmap
