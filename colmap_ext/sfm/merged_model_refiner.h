// Refinement of the merged model.
//
// CSfM (Cui et al., ICIP 2017), section 3.4: once the communities are
// joined in the global frame (model_join.h), "a final bundle adjustment"
// refines all cameras and points. Here the refinement runs COLMAP's
// IncrementalMapper on the full database: it registers images their
// communities left out, where the merged model now sees enough of their
// points, completes and merges tracks over the whole correspondence graph,
// re-triangulates, and alternates global bundle adjustment (Ceres,
// SuiteSparse) with outlier filtering, as the incremental mapper's own
// global refinement does.

#pragma once

#include "colmap_ext/sfm/block_registration.h"
#include "colmap_ext/sfm/reduced_bundle_adjustment.h"

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/database_cache.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/sfm/incremental_mapper.h"
#include "colmap/sfm/observation_manager.h"

#include <functional>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace colmap {

struct MergedModelRefinementOptions {
  // Try to register the images that no community registered: after the
  // alignment, again after the triangulation anew and after every
  // adjustment (each image at most Mapper.max_reg_trials times per loading
  // of the correspondences or block registration); a round that registered
  // images is followed by another. As the incremental mapper, an image that
  // no registration on the model's points takes is tried by structure-less
  // resection (Mapper.structure_less_registration_fallback, on by default),
  // where its camera is one that registered images share.
  bool register_remaining_images = true;

  // Models of communities whose images are offered to this refinement
  // (parts that no kept similarity joins to this one, communities that left
  // the merge) are registered as one block each, through the images the
  // merged model registers in common with them
  // (block_registration.h), instead of image by image; their images the
  // block does not hold are still registered one by one. Part of the
  // registration above: off with it. A block keeps the shape the
  // community's mapper gave its model and saves a local bundle adjustment
  // per image, nine tenths of the registration's time (docs/design.md).
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
  // their borders, and their merge leaves some points split in two), which
  // brings the merged model close to the mapper's accuracy
  // (docs/design.md). The new observations above the mapper's reprojection
  // error are then filtered (the triangulator admits them by angle).
  // (3) Least squares bundle adjustments alternate with filtering, as in
  // the incremental mapper's global refinement (pairs left
  // under-reconstructed are triangulated again after the first), until
  // fewer than `max_refinement_change` of the observations change.
  //
  // The refinement ends close to where step (1) leaves it (its adjustments
  // converge in 2-6 iterations each), so this cap moves the result within
  // what the data cannot tell apart. No value wins on every scene; 200
  // keeps the refinement's time low, where all points took up to 1.7 times
  // as long (docs/design.md).
  int alignment_max_points_per_image = 200;
  bool robust_first_adjustment = true;
  // The observations of the points triangulated anew in step (2) are
  // filtered at this multiple of --Mapper.filter_max_reproj_error before
  // the first adjustment of step (3); 0: not filtered before it. Filtered,
  // the observations the triangulator admitted by angle alone cannot
  // dominate the first least squares adjustment. No value wins on every
  // scene (an open chain's weakly constrained drift ends where the start
  // leaves it); 1 filters as the incremental mapper filters its new points
  // (docs/design.md).
  double triangulation_filter_factor = 1.0;

  // Before the last adjustment (after step (3)) and after it, observations
  // whose reprojection error exceeds this multiple of the model's
  // reprojection noise sigma (reprojection_noise.h) are filtered, where that
  // is below --Mapper.filter_max_reproj_error, and never below a pixel; 0:
  // that fixed threshold alone. Under Gaussian keypoint noise an error
  // beyond 4 sigma has probability exp(-8) = 3e-4: what lies between there
  // and the mapper's 4 px is wrong matches, which the joined tracks (all
  // triangulated at once, then completed and merged) hold more of than the
  // incremental mapper's: on a generated dense scene the merged model's
  // error was in those observations, not in the optimisation. Real
  // photographs at 1024 px (sigma 0.15-0.2 px, a heavy tail: 5% of South
  // Building's observations beyond 6 sigma) are held at the pixel, about
  // 5-6 sigma. 4 is the Gaussian's bound: it halves the error on real open
  // sequences and moves the other scenes by up to a tenth, mostly closer
  // (docs/design.md).
  double final_filter_noise_multiple = 4;

  // Step (3) stops once fewer than this fraction of the observations
  // changed in a round; -1: --Mapper.ba_global_max_refinement_change
  // (0.0005). The last adjustment after the rounds takes the last changes
  // in, so the rounds that the mapper's bound would add move the camera
  // error by under 1%, for a full adjustment each (docs/design.md).
  double max_refinement_change = 0.002;

  // Every bundle adjustment of step (3) runs with the correspondence graph
  // released; it is loaded again from the database for the track
  // completion after it. The peak then holds the larger of the two, not
  // both, for one more database load and mapper start per round (seconds
  // to tens of seconds): a fifth to a third less peak memory at the same
  // camera error (docs/design.md). Without it, the correspondences are
  // held through the rounds, as in the incremental mapper.
  bool reload_correspondences = true;

  // Use Ceres' sparse direct Schur solver at any size. Without it, the
  // solver is chosen as COLMAP's bundle adjuster chooses it: the iterative
  // Schur solver above 1000 images, whose memory grows with the problem
  // alone (a direct solver's factorization grows faster), but whose inexact
  // steps follow the weakly constrained directions of a long open scene
  // poorly: on a loop it saved an eighth of the memory for twice the time,
  // on a long open chain no memory, and it ended twice as far from the
  // truth at the same final cost (docs/design.md).
  bool sparse_solver = true;

  // The bundle adjustments of step (3) adjust the cameras on a subset of
  // the tracks, selected per image over a grid (long, accurate tracks
  // spread over every image), and then refine the other points with the
  // cameras fixed, in problems of at most `max_points_per_problem` points
  // (reduced_bundle_adjustment.h). The last adjustment is over all
  // observations, once the correspondences are released: a subset leaves
  // every camera noisier (the noise averages over fewer observations).
  // Where the tracks are long (a dense scene) it lowers the peak memory by a
  // fifth and the refinement's time by a tenth at about the same camera
  // error (docs/design.md). Without it, every adjustment is over all
  // observations, with the correspondences held.
  bool reduced_adjustment = true;
  // ... where the selected tracks hold at most this fraction of the
  // observations; where they hold more (a sparse scene: few points per
  // grid cell), the round is over all observations: the subset saves
  // little there, and forced it left sparse scenes' cameras further off
  // (docs/design.md). So by default no benchmark scene uses it.
  double max_selected_observation_fraction = 0.5;
  TrackSelectionOptions track_selection;
  int max_points_per_problem = 50000;

  // The bundle adjustments stop once an iteration lowers the cost by less
  // than this fraction. The joined communities are each optimal already, so
  // the merged model converges in a few iterations; COLMAP's default (0:
  // run to --Mapper.ba_global_max_num_iterations) spends most of its time
  // on changes below a millionth of the cost: 1e-6 takes under a quarter of
  // its time for a slightly larger camera error (docs/design.md).
  double function_tolerance = 1e-6;

  // Initial Levenberg-Marquardt trust region radius of the bundle
  // adjustments. Ceres starts at 1e4 and spends the first iterations
  // growing it; the joined model is close to the optimum, where full
  // Gauss-Newton steps are right from the start.
  double initial_trust_region_radius = 1e8;

  bool Check() const;
};

struct MergedModelRefinementSummary {
  // Images no community of the model had registered, registered by the
  // refinement.
  int num_newly_registered_images = 0;
  // Of those, registered as blocks of offered community models.
  int num_block_registered_images = 0;
  // Images the refinement deregistered (misplaced: they observe few of
  // their visible points; or filtered) and registered again.
  int num_reregistered_images = 0;
  // Images deregistered because a camera of their frame came out
  // implausible.
  int num_filtered_images = 0;
  double initial_mean_reprojection_error = 0.0;
  double final_mean_reprojection_error = 0.0;
};

// Completes, merges and refines the joined model with COLMAP's incremental
// mapper machinery on the full database (see the top of this file), one
// method per step. The mapper, triangulation and global bundle adjustment
// options come from `mapper_options` (the user's --Mapper.* flags).
// `community_of_image` tells the community of each joined image (images it
// does not list count as a community of their own). `load_correspondences`
// returns the database cache of the model's images; it is called after the
// alignment and, with `reload_correspondences`, again after every
// adjustment round; the cache is released before the last adjustment.
// `offered_models` are the models (each in its own frame) of communities
// whose images are offered to the refinement, registered as blocks with
// `register_offered_blocks`. As in the incremental mapper, images are
// registered, deregistered and filtered with their whole frame (rig
// snapshot); the model's frames and rigs are the database's.
class MergedModelRefiner {
 public:
  MergedModelRefiner(
      const MergedModelRefinementOptions& options,
      const IncrementalPipelineOptions& mapper_options,
      std::function<std::shared_ptr<const DatabaseCache>()>
          load_correspondences,
      const std::unordered_map<image_t, int>& community_of_image,
      const std::vector<std::shared_ptr<const Reconstruction>>& offered_models,
      std::shared_ptr<Reconstruction> reconstruction);

  // Runs the steps in order, once.
  MergedModelRefinementSummary Run();

 private:
  // (1) A bundle adjustment of all cameras on a reduced set of the joined
  // points, before the correspondences are loaded.
  void Align();
  // Loads the correspondences and begins the incremental mapper on the
  // model.
  void BeginMapper();
  // Begins the incremental mapper on the model with `database_cache`'s
  // correspondences (kept for the pairs the model explains).
  void StartMapper(std::shared_ptr<const DatabaseCache> database_cache);
  // Registers the images no community registered, offered models as blocks
  // first; returns the number of images registered.
  size_t RegisterRemainingImages(bool log_none);
  void RegisterOfferedBlocks();
  // (2) Every point triangulated anew over the correspondence graph.
  void TriangulateAnew();
  // (3) Bundle adjustments alternating with filtering, track completion and
  // registration, until few observations change.
  void AdjustInRounds();
  void DeregisterMisplacedImages();
  // Lets the mapper's per-camera and per-rig counts learn of the frames
  // registered or deregistered outside its own registration.
  void RecountRegisteredFrames();
  // Holds the cameras of the images filtered twice for an implausible
  // camera in the frame of `image_id`, just registered; where the
  // registration's estimate is implausible too, the frame registers again
  // with the database's camera. Whether the frame is registered.
  bool HoldCamerasFilteredTwice(image_t image_id);
  // Registers the frames deregistered as placed apart from their matches
  // that were not registered again, where they were.
  void RestoreFramesApart();
  // Deregisters the frames with an image whose camera came out implausible,
  // as the incremental mapper does.
  void FilterFrames();
  // Ends the mapper and releases the correspondences; the observation
  // manager takes over.
  void ReleaseCorrespondences();
  // The last adjustment, over all observations, between two filterings at
  // the model's reprojection noise.
  void AdjustLastTime();
  // Images deregistered (misplaced or filtered) that are registered again.
  size_t NumRegisteredAgain() const;

  const MergedModelRefinementOptions options_;
  const IncrementalPipelineOptions mapper_options_;
  // Its constant_cameras gain the cameras held (see FilterFrames).
  IncrementalMapper::Options incremental_;
  const IncrementalTriangulator::Options triangulation_;
  const BundleAdjustmentOptions ba_options_;
  const std::function<std::shared_ptr<const DatabaseCache>()>
      load_correspondences_;
  const std::unordered_map<image_t, int> community_of_image_;
  const std::vector<std::shared_ptr<const Reconstruction>> offered_models_;
  std::shared_ptr<Reconstruction> reconstruction_;
  // The mapper while the correspondences are loaded; the observation
  // manager while they are released.
  std::unique_ptr<IncrementalMapper> mapper_;
  // The mapper's correspondences, for the pairs the model explains
  // (unexplained_matches.h); released with them.
  std::shared_ptr<const CorrespondenceGraph> correspondence_graph_;
  std::unique_ptr<ObservationManager> observation_manager_;
  // The images deregistered as misplaced or filtered (a misplaced one at
  // most once).
  std::unordered_set<image_t> deregistered_images_;
  // The poses of the frames deregistered as placed apart from their
  // matches, until they are registered again.
  std::unordered_map<frame_t, Rigid3d> apart_frame_poses_;
  // How often each image was filtered for an implausible camera (see
  // FilterFrames).
  std::unordered_map<image_t, int> num_filterings_;
  // Per image that structure-less resection failed to register, its
  // correspondences with the registered images at that try: it is tried
  // again only with more (a try takes seconds, and the merged model changes
  // little between the rounds).
  std::unordered_map<image_t, size_t> structure_less_tried_;
  // Per offered model: registered as a block, and the images it shared with
  // the model at the last try of this round (a try with no new one is not
  // repeated).
  std::vector<bool> block_registered_;
  std::vector<size_t> num_tried_shared_images_;
  MergedModelRefinementSummary summary_;
};

}  // namespace colmap
