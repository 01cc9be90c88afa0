#include "colmap_ext/sfm/merged_model_refiner.h"

#include "colmap_ext/sfm/reprojection_noise.h"
#include "colmap_ext/sfm/unexplained_matches.h"
#include "colmap_ext/util/option_check.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/estimators/bundle_adjustment.h"
#include "colmap/estimators/bundle_adjustment_ceres.h"
#include "colmap/sfm/incremental_mapper.h"
#include "colmap/sfm/observation_manager.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/threading.h"
#include "colmap/util/timer.h"

#include <algorithm>
#include <functional>
#include <memory>
#include <unordered_set>

namespace colmap {

namespace {

// Ceres options of the refinement's adjustments of the registered images of
// `reconstruction`: the linear solver as COLMAP's Ceres bundle adjuster
// chooses it (by default dense Schur up to 50 images, sparse up to 1000,
// iterative Schur above), or with `sparse_solver` Ceres' sparse Schur solver
// (SuiteSparse) at any size. The solver starts from the options' trust
// region radius and stops once an iteration lowers the cost by less than
// their relative function tolerance.
ceres::Solver::Options RefinementSolverOptions(
    const BundleAdjustmentOptions& options,
    const MergedModelRefinementOptions& refinement,
    const Reconstruction& reconstruction) {
  const CeresBundleAdjustmentOptions& ceres_options =
      *THROW_CHECK_NOTNULL(options.ceres);
  const size_t num_images = reconstruction.NumRegImages();
  ceres::Solver::Options solver_options = ceres_options.solver_options;
  const bool has_sparse =
      solver_options.sparse_linear_algebra_library_type != ceres::NO_SPARSE;
  if (num_images <= static_cast<size_t>(
                        ceres_options.max_num_images_direct_dense_cpu_solver)) {
    solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  } else if (num_images <=
                 static_cast<size_t>(
                     ceres_options.max_num_images_direct_sparse_cpu_solver) &&
             has_sparse) {
    solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  } else {
    solver_options.linear_solver_type = ceres::ITERATIVE_SCHUR;
    solver_options.preconditioner_type = ceres::SCHUR_JACOBI;
  }
  if (refinement.sparse_solver && has_sparse) {
    solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  }
  solver_options.num_threads =
      GetEffectiveNumThreads(solver_options.num_threads);
  solver_options.function_tolerance = refinement.function_tolerance;
  solver_options.initial_trust_region_radius =
      refinement.initial_trust_region_radius;
  return solver_options;
}

// Global bundle adjustment of all registered frames, the gauge fixed as
// COLMAP's mapper fixes it (one frame, one coordinate of a second), over all
// observations or, with `refinement.reduced_adjustment`, on the selected
// tracks followed by the other points with the cameras fixed (where the
// selected tracks hold few enough of the observations), what `incremental`
// holds held: the intrinsics of its constant_cameras, the sensor poses of
// its constant_rigs.
bool AdjustGlobalBundle(const BundleAdjustmentOptions& options,
                        const MergedModelRefinementOptions& refinement,
                        const IncrementalMapper::Options& incremental,
                        ObservationManager* observation_manager,
                        Reconstruction* reconstruction) {
  const size_t num_reg_images = reconstruction->NumRegImages();
  if (num_reg_images < 2) {
    return false;
  }
  observation_manager->FilterObservationsWithNegativeDepth();
  const ceres::Solver::Options solver_options =
      RefinementSolverOptions(options, refinement, *reconstruction);
  std::unordered_set<point3D_t> selected;
  if (refinement.reduced_adjustment) {
    reconstruction->UpdatePoint3DErrors();
    selected = SelectBundleTracks(refinement.track_selection, *reconstruction);
    size_t num_selected_observations = 0;
    for (const point3D_t point3D_id : selected) {
      num_selected_observations +=
          reconstruction->Point3D(point3D_id).track.Length();
    }
    if (num_selected_observations >
        refinement.max_selected_observation_fraction *
            reconstruction->ComputeNumObservations()) {
      selected.clear();  // Hardly smaller: adjust over all observations.
    }
  }
  if (!selected.empty()) {
    const bool usable = AdjustCamerasOnTracks(options,
                                              solver_options,
                                              selected,
                                              reconstruction,
                                              incremental.constant_cameras,
                                              incremental.constant_rigs);
    Timer timer;
    timer.Start();
    const size_t num_refined = RefinePointsWithFixedCameras(
        options, selected, refinement.max_points_per_problem, reconstruction);
    LOG(INFO) << StringPrintf(
        "Refined the other %d points with the cameras fixed (%.1fs)",
        static_cast<int>(num_refined),
        timer.ElapsedSeconds());
    return usable;
  }

  const ceres::Solver::Summary summary =
      AdjustAllObservations(options,
                            solver_options,
                            reconstruction,
                            incremental.constant_cameras,
                            incremental.constant_rigs);
  if (summary.num_residuals <= 0) {
    return false;
  }
  LOG(INFO) << StringPrintf(
      "Bundle adjustment of %d images, %d residuals: %s",
      static_cast<int>(num_reg_images),
      summary.num_residuals,
      SolverSummaryToString(
          solver_options, summary, summary.total_time_in_seconds)
          .c_str());
  return summary.IsSolutionUsable();
}

BundleAdjustmentOptions RobustOptions(BundleAdjustmentOptions options) {
  THROW_CHECK_NOTNULL(options.ceres);
  options.ceres->loss_function_type =
      CeresBundleAdjustmentOptions::LossFunctionType::SOFT_L1;
  options.ceres->loss_function_scale = 1.0;
  return options;
}

// Bundle adjusts all cameras of `reconstruction` on the points seen from
// two communities (or from an image of none) and, per image, the
// `alignment_max_points_per_image` points with the longest tracks (those
// that tie the most images together), intrinsics fixed, as are the sensor
// poses of `constant_rigs`. The other points are left as they were.
void AlignCameras(const MergedModelRefinementOptions& options,
                  const BundleAdjustmentOptions& ba_options,
                  const std::unordered_set<rig_t>& constant_rigs,
                  const std::unordered_map<image_t, int>& community_of_image,
                  ObservationManager* observation_manager,
                  Reconstruction* reconstruction) {
  if (reconstruction->NumRegImages() < 2) {
    return;
  }
  observation_manager->FilterObservationsWithNegativeDepth();
  std::unordered_set<point3D_t> kept;
  // Every point seen from two communities: these tie them together.
  for (const auto& [point3D_id, point3D] : reconstruction->Points3D()) {
    int community = -1;
    for (const TrackElement& track_el : point3D.track.Elements()) {
      const auto it = community_of_image.find(track_el.image_id);
      const int other = it == community_of_image.end() ? -2 : it->second;
      if (community != -1 && other != community) {
        kept.insert(point3D_id);
        break;
      }
      community = other;
    }
  }
  // Per image, the longest tracks (a point a single image holds constrains
  // nothing).
  for (const image_t image_id : reconstruction->RegImageIds()) {
    std::vector<std::pair<size_t, point3D_t>> points;
    for (const Point2D& point2D : reconstruction->Image(image_id).Points2D()) {
      if (!point2D.HasPoint3D()) {
        continue;
      }
      const size_t track_length =
          reconstruction->Point3D(point2D.point3D_id).track.Length();
      if (track_length >= 2) {
        points.emplace_back(track_length, point2D.point3D_id);
      }
    }
    const size_t num_kept =
        std::min<size_t>(points.size(), options.alignment_max_points_per_image);
    std::partial_sort(points.begin(),
                      points.begin() + num_kept,
                      points.end(),
                      std::greater<std::pair<size_t, point3D_t>>());
    for (size_t k = 0; k < num_kept; ++k) {
      kept.insert(points[k].second);
    }
  }
  // The communities estimated the intrinsics already; only the poses need
  // to come together.
  BundleAdjustmentOptions alignment_options = ba_options;
  alignment_options.refine_focal_length = false;
  alignment_options.refine_principal_point = false;
  alignment_options.refine_extra_params = false;
  AdjustCamerasOnTracks(
      alignment_options,
      RefinementSolverOptions(alignment_options, options, *reconstruction),
      kept,
      reconstruction,
      /*constant_cameras=*/{},
      constant_rigs);
}

}  // namespace

bool MergedModelRefinementOptions::Check() const {
  CHECK_OPTION_GT(alignment_max_points_per_image, 0);
  CHECK_OPTION_GE(triangulation_filter_factor, 0);
  CHECK_OPTION_GE(final_filter_noise_multiple, 0);
  if (!CheckFlag(max_refinement_change == -1 || max_refinement_change >= 0,
                 "ba_max_refinement_change",
                 max_refinement_change,
                 "0 or more, or -1 for "
                 "--Mapper.ba_global_max_refinement_change") ||
      !CheckFlag(function_tolerance >= 0,
                 "ba_function_tolerance",
                 function_tolerance,
                 "0 or more")) {
    return false;
  }
  CHECK_OPTION(track_selection.Check());
  CHECK_OPTION_GT(max_points_per_problem, 0);
  CHECK_OPTION_GE(max_selected_observation_fraction, 0);
  CHECK_OPTION_LE(max_selected_observation_fraction, 1);
  CHECK_OPTION_GT(initial_trust_region_radius, 0);
  CHECK_OPTION(block_registration.Check());
  return true;
}

MergedModelRefiner::MergedModelRefiner(
    const MergedModelRefinementOptions& options,
    const IncrementalPipelineOptions& mapper_options,
    std::function<std::shared_ptr<const DatabaseCache>()> load_correspondences,
    const std::unordered_map<image_t, int>& community_of_image,
    const std::vector<std::shared_ptr<const Reconstruction>>& offered_models,
    std::shared_ptr<Reconstruction> reconstruction)
    : options_(options),
      mapper_options_(mapper_options),
      incremental_(mapper_options.Mapper()),
      triangulation_(mapper_options.Triangulation()),
      ba_options_(mapper_options.GlobalBundleAdjustment()),
      load_correspondences_(std::move(load_correspondences)),
      community_of_image_(community_of_image),
      offered_models_(offered_models),
      reconstruction_(std::move(reconstruction)),
      block_registered_(offered_models.size(), false) {
  THROW_CHECK(options_.Check());
  THROW_CHECK(mapper_options_.Check());
  THROW_CHECK_NOTNULL(reconstruction_);
}

MergedModelRefinementSummary MergedModelRefiner::Run() {
  reconstruction_->UpdatePoint3DErrors();
  summary_.initial_mean_reprojection_error =
      reconstruction_->ComputeMeanReprojectionError();
  Align();
  BeginMapper();
  RegisterRemainingImages(/*log_none=*/true);
  TriangulateAnew();
  RegisterRemainingImages(/*log_none=*/false);
  AdjustInRounds();
  AdjustLastTime();
  reconstruction_->UpdatePoint3DErrors();
  summary_.final_mean_reprojection_error =
      reconstruction_->ComputeMeanReprojectionError();
  return summary_;
}

void MergedModelRefiner::Align() {
  // 1. Alignment: the joined communities are each right, but where they
  // meet they are only as close as the averaged similarities put them. A
  // bundle adjustment of all cameras on a reduced set of the joined points
  // (robust loss, if asked), those merged across the borders among them,
  // pulls them together. It runs before the correspondences are loaded, so
  // that its problem and the correspondence graph are never held at once.
  Timer timer;
  timer.Start();
  {
    ObservationManager observation_manager(*reconstruction_);
    AlignCameras(options_,
                 options_.robust_first_adjustment ? RobustOptions(ba_options_)
                                                  : ba_options_,
                 incremental_.constant_rigs,
                 community_of_image_,
                 &observation_manager,
                 reconstruction_.get());
  }
  ReleaseFreedMemory();
  LOG(INFO) << StringPrintf("Aligned the cameras (%.1fs; %s)",
                            timer.ElapsedSeconds(),
                            ProcessMemoryToString(ReadProcessMemory()).c_str());
}

void MergedModelRefiner::BeginMapper() {
  // Step (2) deletes every point. Where no image is left to register before
  // it (every image of the correspondence graph is registered and no model
  // is offered), they are deleted before the mapper starts: its start counts
  // the correspondences of every observation, for points about to go (3 s
  // on a generated dense scene of 560 images).
  std::shared_ptr<const DatabaseCache> database_cache = load_correspondences_();
  if (offered_models_.empty() &&
      std::all_of(database_cache->Images().begin(),
                  database_cache->Images().end(),
                  [&](const auto& image) {
                    return reconstruction_->ExistsImage(image.first) &&
                           reconstruction_->Image(image.first).HasPose();
                  })) {
    for (const point3D_t point3D_id : reconstruction_->Point3DIds()) {
      reconstruction_->DeletePoint3D(point3D_id);
    }
  }
  StartMapper(std::move(database_cache));
}

void MergedModelRefiner::StartMapper(
    std::shared_ptr<const DatabaseCache> database_cache) {
  correspondence_graph_ = database_cache->CorrespondenceGraph();
  mapper_ = std::make_unique<IncrementalMapper>(std::move(database_cache));
  mapper_->BeginReconstruction(reconstruction_);
}

size_t MergedModelRefiner::NumRegisteredAgain() const {
  return static_cast<size_t>(
      std::count_if(deregistered_images_.begin(),
                    deregistered_images_.end(),
                    [&](const image_t image_id) {
                      return reconstruction_->ExistsImage(image_id) &&
                             reconstruction_->Image(image_id).HasPose();
                    }));
}

void MergedModelRefiner::RegisterOfferedBlocks() {
  if (!options_.register_offered_blocks) {
    return;
  }
  for (size_t k = 0; k < offered_models_.size(); ++k) {
    if (block_registered_[k]) {
      continue;
    }
    const Reconstruction& model = *offered_models_[k];
    size_t num_shared_images = 0;
    for (const image_t image_id : model.RegImageIds()) {
      num_shared_images += reconstruction_->ExistsImage(image_id) &&
                           reconstruction_->Image(image_id).HasPose();
    }
    if (num_shared_images == num_tried_shared_images_[k]) {
      continue;
    }
    num_tried_shared_images_[k] = num_shared_images;
    const BlockRegistration block = EstimateBlockRegistration(
        model, *reconstruction_, options_.block_registration);
    if (!block.success) {
      continue;
    }
    block_registered_[k] = true;
    ApplyBlockRegistration(model, block, reconstruction_.get());
    // The mapper learns of the images as registered; then they are
    // triangulated with the images registered before.
    RecountRegisteredFrames();
    for (const image_t image_id : block.image_ids) {
      mapper_->TriangulateImage(triangulation_, image_id);
    }
    // Not the next local adjustment's business (it would take them all).
    mapper_->ClearModifiedPoints3D();
    summary_.num_block_registered_images +=
        static_cast<int>(block.image_ids.size());
    LOG(INFO) << StringPrintf(
        "Registered %d images of an offered community model as one block, "
        "through %d images both registered (similarity from %d of %d "
        "points)",
        static_cast<int>(block.image_ids.size()),
        block.num_shared_images,
        block.num_inliers,
        block.num_correspondences);
  }
}

size_t MergedModelRefiner::RegisterRemainingImages(const bool log_none) {
  if (!options_.register_remaining_images) {
    return 0;
  }
  Timer timer;
  timer.Start();
  const size_t num_reg_images_before = reconstruction_->NumRegImages();
  const int num_block_images_before = summary_.num_block_registered_images;
  const size_t num_again_before = NumRegisteredAgain();
  num_tried_shared_images_.assign(offered_models_.size(), 0);
  RegisterOfferedBlocks();
  // As the incremental mapper (IncrementalPipeline): each image is tried
  // against the model's points first and, where none registers so and
  // Mapper.structure_less_registration_fallback is on, by structure-less
  // resection from its correspondences with the registered images.
  std::vector<bool> structure_less_passes;
  if (!mapper_options_.structure_less_registration_only) {
    structure_less_passes.push_back(false);
  }
  if (mapper_options_.structure_less_registration_fallback ||
      mapper_options_.structure_less_registration_only) {
    structure_less_passes.push_back(true);
  }
  const auto register_image = [this](const image_t image_id,
                                     const bool structure_less) {
    const auto filterings = num_filterings_.find(image_id);
    if (filterings != num_filterings_.end() && filterings->second >= 3) {
      return false;
    }
    if (!structure_less) {
      return mapper_->RegisterNextImage(incremental_, image_id) &&
             HoldCamerasFilteredTwice(image_id);
    }
    // Its minimal solver takes the camera's intrinsics as given: only those
    // that registered images share and have estimated are known.
    const auto& num_reg_images_per_camera = mapper_->NumRegImagesPerCamera();
    const auto camera_images = num_reg_images_per_camera.find(
        reconstruction_->Image(image_id).CameraId());
    if (camera_images == num_reg_images_per_camera.end() ||
        camera_images->second == 0) {
      return false;
    }
    const size_t num_correspondences =
        mapper_->ObservationManager().NumVisibleCorrespondences(image_id);
    const auto tried = structure_less_tried_.find(image_id);
    if (tried != structure_less_tried_.end() &&
        num_correspondences <= tried->second) {
      return false;
    }
    if (!mapper_->RegisterNextStructureLessImage(incremental_, image_id)) {
      structure_less_tried_[image_id] = num_correspondences;
      return false;
    }
    return HoldCamerasFilteredTwice(image_id);
  };
  // Registers the best next image that registers, with its local
  // adjustment, and offers the blocks again; false where none registers.
  const auto register_next_image = [&]() {
    for (const bool structure_less : structure_less_passes) {
      for (const image_t image_id :
           mapper_->FindNextImages(incremental_, structure_less)) {
        if (!register_image(image_id, structure_less)) {
          continue;
        }
        // The image registers its frame: all the frame's images are
        // triangulated.
        const Frame& frame = *reconstruction_->Image(image_id).FramePtr();
        for (const data_t& data_id : frame.ImageIds()) {
          mapper_->TriangulateImage(triangulation_, data_id.id);
        }
        mapper_->IterativeLocalRefinement(
            mapper_options_.ba_local_max_refinements,
            mapper_options_.ba_local_max_refinement_change,
            incremental_,
            mapper_options_.LocalBundleAdjustment(),
            triangulation_,
            image_id);
        RegisterOfferedBlocks();
        return true;
      }
    }
    return false;
  };
  // The next image is chosen with the last one's points.
  while (register_next_image()) {
  }
  const size_t num_registered =
      reconstruction_->NumRegImages() - num_reg_images_before;
  const size_t num_again = NumRegisteredAgain() - num_again_before;
  summary_.num_newly_registered_images +=
      static_cast<int>(num_registered - num_again);
  summary_.num_reregistered_images += static_cast<int>(num_again);
  if (num_registered > 0 || log_none) {
    LOG(INFO) << StringPrintf(
        "Registered %d images that no community of the model had "
        "registered, %d of them as blocks, and %d deregistered ones again "
        "(%.1fs)",
        static_cast<int>(num_registered - num_again),
        summary_.num_block_registered_images - num_block_images_before,
        static_cast<int>(num_again),
        timer.ElapsedSeconds());
  }
  return num_registered;
}

void MergedModelRefiner::TriangulateAnew() {
  // 2. With the cameras in place, all points are triangulated anew over the
  // whole correspondence graph, as the incremental mapper builds its tracks
  // (the communities' tracks end at their borders, and their merge leaves
  // some points split in two). The triangulator admits an observation by
  // its angle to the ray (2 degrees by default: tens of pixels), where the
  // incremental mapper filters each image's new points by reprojection
  // error after its local adjustment; filtered before the first least
  // squares adjustment, those observations cannot dominate it: the first
  // round converges in a few iterations instead of tens, and a dense
  // scene's cameras end closer (docs/design.md).
  Timer timer;
  timer.Start();
  for (const point3D_t point3D_id : reconstruction_->Point3DIds()) {
    mapper_->ObservationManager().DeletePoint3D(point3D_id);
  }
  for (const image_t image_id : reconstruction_->RegImageIds()) {
    mapper_->TriangulateImage(triangulation_, image_id);
  }
  const size_t num_completed = mapper_->CompleteAndMergeTracks(triangulation_);
  size_t num_filtered = 0;
  if (options_.triangulation_filter_factor > 0) {
    IncrementalMapper::Options filter_options = incremental_;
    filter_options.filter_max_reproj_error *=
        options_.triangulation_filter_factor;
    num_filtered = mapper_->FilterPoints(filter_options);
  }
  LOG(INFO) << StringPrintf(
      "Triangulated %d points anew, completed and merged %d observations, "
      "filtered %d (%.1fs; %s)",
      static_cast<int>(reconstruction_->NumPoints3D()),
      static_cast<int>(num_completed),
      static_cast<int>(num_filtered),
      timer.ElapsedSeconds(),
      ProcessMemoryToString(ReadProcessMemory()).c_str());
}

void MergedModelRefiner::RecountRegisteredFrames() {
  // The mapper counts the registered frames per camera and rig as it
  // begins a reconstruction; frames registered or deregistered outside its
  // own registration are counted by beginning again.
  mapper_->EndReconstruction(/*discard=*/false);
  mapper_->BeginReconstruction(reconstruction_);
}

void MergedModelRefiner::ReleaseCorrespondences() {
  mapper_->EndReconstruction(/*discard=*/false);
  mapper_.reset();
  correspondence_graph_.reset();
  ReleaseFreedMemory();
  observation_manager_ = std::make_unique<ObservationManager>(*reconstruction_);
}

void MergedModelRefiner::DeregisterMisplacedImages() {
  // A registered image whose observations are few against the points of the
  // other images its keypoints correspond to (ObservationManager's visible
  // points: what the mapper ranks candidate images by) sits where its
  // matches do not: it is deregistered, once, and registered again with the
  // others' poses as they are now. Likewise an image held by fewer
  // observations than the mapper needs to register one
  // (Mapper.abs_pose_min_num_inliers). A community's mapper registers an
  // image by what that community sees: on one matching of South Building a
  // community placed an image of its own 6 units off (extent 11), by
  // inliers no other community shared; in the merged model it kept 39
  // observations of its visible points, where the median image kept 2011.
  // A misplaced image's frame is deregistered whole: its images share the
  // pose.
  constexpr double kMinObservedVisibleFraction = 0.1;
  ObservationManager& observations = mapper_->ObservationManager();
  std::vector<frame_t> misplaced_frame_ids;
  std::unordered_set<frame_t> misplaced_frame_id_set;
  double min_fraction = 1;
  for (const image_t image_id : reconstruction_->RegImageIds()) {
    const Image& image = reconstruction_->Image(image_id);
    const size_t num_observed = image.NumPoints3D();
    const size_t num_visible = observations.NumVisiblePoints3D(image_id);
    const double fraction =
        num_visible == 0 ? 1.0
                         : static_cast<double>(num_observed) / num_visible;
    min_fraction = std::min(min_fraction, fraction);
    if ((num_observed <
             static_cast<size_t>(incremental_.abs_pose_min_num_inliers) ||
         fraction < kMinObservedVisibleFraction) &&
        deregistered_images_.count(image_id) == 0 &&
        misplaced_frame_id_set.insert(image.FrameId()).second) {
      misplaced_frame_ids.push_back(image.FrameId());
    }
  }
  LOG(INFO) << StringPrintf(
      "Lowest share of an image's visible points it observes: %.3f",
      min_fraction);
  // Likewise a group of images that the pairs the model explains do not
  // join to the rest (unexplained_matches.h): a community's mapper placed
  // them, with their points, apart from what their matches say.
  size_t num_apart = 0;
  for (const image_t image_id : FindImagesApartFromTheirMatches(
           *reconstruction_, *correspondence_graph_)) {
    if (deregistered_images_.count(image_id) == 0) {
      ++num_apart;
      const frame_t frame_id = reconstruction_->Image(image_id).FrameId();
      if (misplaced_frame_id_set.insert(frame_id).second) {
        misplaced_frame_ids.push_back(frame_id);
        apart_frame_poses_.emplace(
            frame_id, reconstruction_->Frame(frame_id).RigFromWorld());
      }
    }
  }
  size_t num_misplaced_images = 0;
  for (const frame_t frame_id : misplaced_frame_ids) {
    for (const data_t& data_id : reconstruction_->Frame(frame_id).ImageIds()) {
      deregistered_images_.insert(data_id.id);
      ++num_misplaced_images;
    }
    observations.DeRegisterFrame(frame_id);
  }
  if (!misplaced_frame_ids.empty()) {
    RecountRegisteredFrames();
    LOG(INFO) << StringPrintf(
        "Deregistered %d images that observe few of their visible points or "
        "that their matches place elsewhere (%d), to register them again",
        static_cast<int>(num_misplaced_images),
        static_cast<int>(num_apart));
  }
}

void MergedModelRefiner::RestoreFramesApart() {
  // A group that its matches place apart but that the rest of the model
  // cannot take in (no place there explains its images: where the whole
  // mapper misplaces it too) keeps the place its community gave it, rather
  // than leave the model: its frames are registered there again and their
  // images triangulated.
  size_t num_restored = 0;
  for (const auto& [frame_id, rig_from_world] : apart_frame_poses_) {
    if (reconstruction_->Frame(frame_id).HasPose()) {
      continue;
    }
    reconstruction_->Frame(frame_id).SetRigFromWorld(rig_from_world);
    mapper_->ObservationManager().RegisterFrame(frame_id);
    for (const data_t& data_id : reconstruction_->Frame(frame_id).ImageIds()) {
      mapper_->TriangulateImage(triangulation_, data_id.id);
      ++num_restored;
    }
  }
  apart_frame_poses_.clear();
  if (num_restored > 0) {
    RecountRegisteredFrames();
    LOG(INFO) << StringPrintf(
        "%d images their matches place elsewhere could not be registered "
        "there: they keep their place",
        static_cast<int>(num_restored));
  }
}

void MergedModelRefiner::FilterFrames() {
  // As the incremental mapper after each global refinement: frames with an
  // image whose camera came out implausible (focal length or distortion
  // beyond Mapper.min/max_focal_length_ratio and max_extra_param) or without
  // observations are deregistered, to be registered again with their camera
  // reset to the database's (IncrementalMapper::RegisterNextImage).
  const std::vector<image_t> reg_image_ids = reconstruction_->RegImageIds();
  if (mapper_->FilterFrames(incremental_) == 0) {
    return;
  }
  for (const image_t image_id : reg_image_ids) {
    if (!reconstruction_->Image(image_id).HasPose()) {
      ++summary_.num_filtered_images;
      deregistered_images_.insert(image_id);
      ++num_filterings_[image_id];
    }
  }
}

bool MergedModelRefiner::HoldCamerasFilteredTwice(const image_t image_id) {
  // An image filtered twice has a camera the adjustments cannot estimate
  // from what the model sees of it (on an open chain with a camera per
  // image, a focal length that shrank to a few dozen pixels, twice). Its
  // camera is then estimated once more, as it registers, from its matches
  // to the model's points, and held from there on, as the mapper holds the
  // cameras a user fixes (Mapper.constant_cameras). Where that estimate is
  // implausible too, the frame registers again with the database's camera
  // held instead. Filtered a third time, the image is not registered again.
  const frame_t frame_id = reconstruction_->Image(image_id).FrameId();
  bool implausible = false;
  for (const data_t& data_id : reconstruction_->Frame(frame_id).ImageIds()) {
    const auto filterings = num_filterings_.find(data_id.id);
    if (filterings == num_filterings_.end() || filterings->second != 2) {
      continue;
    }
    const Image& image = reconstruction_->Image(data_id.id);
    const Camera& camera = *image.CameraPtr();
    if (!incremental_.constant_cameras.insert(camera.camera_id).second) {
      continue;
    }
    if (camera.HasBogusParams(incremental_.min_focal_length_ratio,
                              incremental_.max_focal_length_ratio,
                              incremental_.max_extra_param)) {
      LOG(INFO) << StringPrintf(
          "%s: its camera came out implausible twice and again as it "
          "registered (focal length %.1f); it registers with the database's "
          "camera, held",
          image.Name().c_str(),
          camera.MeanFocalLength());
      implausible = true;
    } else {
      LOG(INFO) << StringPrintf(
          "%s: its camera came out implausible twice; it is held as the "
          "image registered (focal length %.1f)",
          image.Name().c_str(),
          camera.MeanFocalLength());
    }
  }
  if (!implausible) {
    return true;
  }
  // The frame's pose was estimated with the implausible camera. Registering
  // again, the mapper resets an implausible camera to the database's, and
  // holds it there (IncrementalMapper::RegisterNextImage).
  mapper_->ObservationManager().DeRegisterFrame(frame_id);
  RecountRegisteredFrames();
  return mapper_->RegisterNextImage(incremental_, image_id);
}

void MergedModelRefiner::AdjustInRounds() {
  // 3. As the incremental mapper's global refinement: least squares bundle
  // adjustment alternating with filtering and track completion until few
  // observations change. With `reload_correspondences`, every adjustment
  // runs with the correspondences released and they are loaded again after
  // it, so that its problem and the correspondence graph are never held at
  // once.
  const double max_change =
      options_.max_refinement_change >= 0
          ? options_.max_refinement_change
          : mapper_options_.ba_global_max_refinement_change;
  for (int i = 0; i < std::max(1, mapper_options_.ba_global_max_refinements);
       ++i) {
    if (options_.reload_correspondences) {
      ReleaseCorrespondences();
    }
    const size_t num_observations = reconstruction_->ComputeNumObservations();
    AdjustGlobalBundle(
        ba_options_,
        options_,
        incremental_,
        mapper_ ? &mapper_->ObservationManager() : observation_manager_.get(),
        reconstruction_.get());
    reconstruction_->Normalize();
    if (!mapper_) {
      observation_manager_.reset();
      ReleaseFreedMemory();
      StartMapper(load_correspondences_());
    }
    DeregisterMisplacedImages();
    FilterFrames();
    const size_t num_registered = RegisterRemainingImages(/*log_none=*/false);
    RestoreFramesApart();
    // Pairs the first triangulation left under-reconstructed (a border
    // still a little apart) are triangulated again with the adjusted poses,
    // once (the triangulator tries a pair once: a mapper loaded anew would
    // try them all again).
    size_t num_changed = mapper_->CompleteAndMergeTracks(triangulation_);
    if (i == 0) {
      num_changed += mapper_->Retriangulate(triangulation_);
    }
    num_changed += mapper_->FilterPoints(incremental_);
    const double changed =
        num_observations == 0
            ? 0
            : static_cast<double>(num_changed) / num_observations;
    LOG(INFO) << StringPrintf(
        "Refinement %d: %d observations (%.5f) changed (%s)",
        i + 1,
        static_cast<int>(num_changed),
        changed,
        ProcessMemoryToString(ReadProcessMemory()).c_str());
    // Newly registered images are adjusted in one more round.
    if (changed < max_change && num_registered == 0) {
      break;
    }
  }
  // Images whose camera is still implausible stay out of the last
  // adjustment, as they stay out of the incremental mapper's model.
  FilterFrames();
  // The correspondences are not needed any more: the last adjustment runs
  // without them in memory.
  ReleaseCorrespondences();
}

void MergedModelRefiner::AdjustLastTime() {
  // The last track completion and filtering changed a few observations;
  // adjusting once more on them moves the cameras noticeably, as the
  // adjustments before stopped where those observations held them: on a
  // generated loop of 420 images the median camera error went from 0.022 to
  // 0.0165 (colmap mapper: 0.0164) for 4 seconds. It is over all
  // observations: what the tracks left out of a reduced adjustment tell
  // about every camera (its noise averages over all of them).
  //
  // Before it, the observations beyond `final_filter_noise_multiple` times
  // the model's reprojection noise are filtered (reprojection_noise.h).
  // Never below a pixel: real photographs at 1024 px have a heavy tail of
  // errors beyond a few times their noise of 0.15-0.2 px
  // (merged_model_refiner.h).
  constexpr double kMinFinalMaxReprojError = 1.0;
  const double final_max_reproj_error = NoiseRelativeReprojectionThreshold(
      *reconstruction_,
      options_.final_filter_noise_multiple,
      std::min(kMinFinalMaxReprojError, incremental_.filter_max_reproj_error),
      incremental_.filter_max_reproj_error);
  if (final_max_reproj_error < incremental_.filter_max_reproj_error) {
    const size_t num_filtered_noise = observation_manager_->FilterAllPoints3D(
        final_max_reproj_error, incremental_.filter_min_tri_angle);
    LOG(INFO) << StringPrintf(
        "Filtered %d observations above %.2f px (%g times the reprojection "
        "noise) before the last adjustment",
        static_cast<int>(num_filtered_noise),
        final_max_reproj_error,
        options_.final_filter_noise_multiple);
  }
  MergedModelRefinementOptions full_options = options_;
  full_options.reduced_adjustment = false;
  AdjustGlobalBundle(ba_options_,
                     full_options,
                     incremental_,
                     observation_manager_.get(),
                     reconstruction_.get());
  // As after every adjustment before (and the incremental mapper's last),
  // the observations it left too far from their points, or behind their
  // camera, are filtered: a two-view point behind a camera gave a generated
  // chain's model a mean reprojection error of 5e149 pixels.
  const size_t num_filtered_last = observation_manager_->FilterAllPoints3D(
      final_max_reproj_error, incremental_.filter_min_tri_angle);
  LOG(INFO) << StringPrintf(
      "Filtered %d observations after the last adjustment",
      static_cast<int>(num_filtered_last));
}

}  // namespace colmap
