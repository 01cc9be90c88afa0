#include "colmap_ext/sfm/merged_model_refiner.h"

#include "colmap_ext/scene/model_evaluation.h"
#include "colmap_ext/scene/synthetic_scene.h"
#include "colmap_ext/util/testing.h"

#include "colmap/geometry/pose.h"
#include "colmap/math/math.h"
#include "colmap/math/random.h"
#include "colmap/scene/database_cache.h"
#include "colmap/scene/synthetic.h"

#include <algorithm>
#include <filesystem>
#include <set>
#include <vector>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// A generated scene of two clusters (or one; one camera for all images or one
// per image) in its database, and its ground truth as a merged model of two
// communities (the clusters) to refine.
struct RefinerScene {
  explicit RefinerScene(const int num_clusters = 2,
                        const bool single_camera = true) {
    SyntheticSceneOptions scene_options;
    scene_options.num_clusters = num_clusters;
    scene_options.single_camera = single_camera;
    scene_options.num_images_per_cluster = 15;
    scene_options.num_images_per_link = num_clusters > 1 ? 10 : 0;
    scene_options.close_loop = false;
    scene_options.keypoint_noise = 0.5;
    scene_options.seed = 12;
    const std::shared_ptr<Database> database = Database::Open(
        std::filesystem::path(CreateTestFolder()) / "database.db");
    SynthesizeCommunityScene(scene_options, &scene, database.get());
    DatabaseCache::Options cache_options;
    cache_options.min_num_matches = 15;
    database_cache = DatabaseCache::Create(*database, cache_options);
    model = std::make_shared<Reconstruction>(scene.ground_truth);
    for (const image_t image_id : model->RegImageIds()) {
      community_of_image[image_id] = scene.image_cluster.at(image_id) == 1;
    }
    truth = EvaluateModel(*model, scene.ground_truth);
  }

  // Registered images of the first cluster, but the model's first two
  // (the gauge of the adjustment).
  std::vector<image_t> FirstClusterImages() const {
    const std::vector<image_t> reg_image_ids = model->RegImageIds();
    std::vector<image_t> image_ids;
    for (const image_t image_id : reg_image_ids) {
      if (scene.image_cluster.at(image_id) == 0 &&
          image_id != reg_image_ids[0] && image_id != reg_image_ids[1]) {
        image_ids.push_back(image_id);
      }
    }
    return image_ids;
  }

  MergedModelRefinementSummary Refine(
      IncrementalPipelineOptions mapper_options =
          IncrementalPipelineOptions()) {
    mapper_options.num_threads = 1;
    return MergedModelRefiner(
               MergedModelRefinementOptions(),
               mapper_options,
               [this]() { return database_cache; },
               community_of_image,
               /*offered_models=*/{},
               model)
        .Run();
  }

  SyntheticScene scene;
  std::shared_ptr<const DatabaseCache> database_cache;
  std::shared_ptr<Reconstruction> model;
  std::unordered_map<image_t, int> community_of_image;
  ModelEvaluation truth;
};

// A community's mapper can register an image by what that community sees,
// far from where the whole model puts it (on South Building, 6 units off by
// points no other community had). In the merged model it then holds few
// observations, and the refinement must register it again rather than keep
// it there or drop it.
TEST(MergedModelRefiner, RegistersAgainAnImageItHoldsByFewObservations) {
  RefinerScene scene;
  Reconstruction& model = *scene.model;
  // An image of the first cluster, turned by 30 degrees and moved by a
  // quarter of the extent.
  const image_t misplaced = scene.FirstClusterImages().front();
  const Image& misplaced_image = model.Image(misplaced);
  model.Frame(misplaced_image.FrameId())
      .SetCamFromWorld(
          misplaced_image.CameraId(),
          Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(
                      DegToRad(30.0), Eigen::Vector3d::UnitY())),
                  Eigen::Vector3d(0.25 * scene.truth.extent, 0, 0)) *
              misplaced_image.CamFromWorld());
  ASSERT_GT(EvaluateModel(model, scene.scene.ground_truth).max_position_error,
            0.1 * scene.truth.extent);
  // Its observations there were of points no other community has: none is
  // left in the merged model.
  for (point2D_t point2D_idx = 0;
       point2D_idx < model.Image(misplaced).NumPoints2D();
       ++point2D_idx) {
    if (model.Image(misplaced).Point2D(point2D_idx).HasPoint3D()) {
      model.DeleteObservation(misplaced, point2D_idx);
    }
  }

  const MergedModelRefinementSummary summary = scene.Refine();
  EXPECT_EQ(summary.num_reregistered_images, 1);
  EXPECT_EQ(summary.num_newly_registered_images, 0);
  EXPECT_TRUE(model.Image(misplaced).HasPose());
  EXPECT_EQ(model.NumRegImages(), scene.scene.ground_truth.NumRegImages());
  EXPECT_LT(EvaluateModel(model, scene.scene.ground_truth).max_position_error,
            0.01 * scene.truth.extent);
}

// A community's mapper can also register a group of its images, with their
// points, onto a look-alike structure (on South Building, a stretch of
// facade): the group fits its own observations, but its matches with the
// images around it are not explained. The refinement registers the group
// again where its matches put it.
TEST(MergedModelRefiner, RegistersAgainAGroupItsMatchesPlaceElsewhere) {
  RefinerScene scene;
  Reconstruction& model = *scene.model;
  const std::vector<image_t> first_cluster = scene.FirstClusterImages();
  ASSERT_GE(first_cluster.size(), 8);
  const std::vector<image_t> misplaced(first_cluster.begin() + 4,
                                       first_cluster.begin() + 8);
  // Moved together by a fifth of the extent, with their own copy of every
  // point they see, as a community's mapper places a stretch on a
  // look-alike structure: they fit their own observations, the rest fits
  // its own, and only the matches between the two say that they are apart.
  MoveImagesWithTheirPoints({misplaced.begin(), misplaced.end()},
                            Eigen::Vector3d(0.2 * scene.truth.extent, 0, 0),
                            &model);
  ASSERT_GT(EvaluateModel(model, scene.scene.ground_truth).max_position_error,
            0.1 * scene.truth.extent);

  const MergedModelRefinementSummary summary = scene.Refine();
  EXPECT_EQ(summary.num_reregistered_images, misplaced.size());
  EXPECT_EQ(model.NumRegImages(), scene.scene.ground_truth.NumRegImages());
  EXPECT_LT(EvaluateModel(model, scene.scene.ground_truth).max_position_error,
            0.01 * scene.truth.extent);
}

// COLMAP's incremental mapper registers an image that too few of its
// matches to the model's points place by structure-less resection, from its
// matches with the registered images
// (Mapper.structure_less_registration_fallback, on by default; `_only`: that
// alone), and the refinement registers the images no community registered
// as the mapper does, but only where the image's camera is known: the
// resection takes the intrinsics as given, and an image's own camera holds
// only the database's guess (on open chains with a camera per image it
// placed images far off).
TEST(MergedModelRefiner, RegistersStructureLessWhereTheCameraIsKnown) {
  for (const bool single_camera : {true, false}) {
    RefinerScene scene(/*num_clusters=*/1, single_camera);
    Reconstruction& model = *scene.model;
    const image_t image_id = scene.FirstClusterImages().front();
    model.DeRegisterFrame(model.Image(image_id).FrameId());

    IncrementalPipelineOptions mapper_options;
    mapper_options.structure_less_registration_only = true;
    const MergedModelRefinementSummary summary = scene.Refine(mapper_options);
    // The refinement drops the images it leaves out from the model.
    const bool registered =
        model.ExistsImage(image_id) && model.Image(image_id).HasPose();
    EXPECT_EQ(registered, single_camera);
    EXPECT_EQ(summary.num_newly_registered_images, single_camera ? 1 : 0);
    EXPECT_EQ(
        model.NumRegImages(),
        scene.scene.ground_truth.NumRegImages() - (single_camera ? 0 : 1));
    EXPECT_LT(EvaluateModel(model, scene.scene.ground_truth).max_position_error,
              0.01 * scene.truth.extent);
  }
}

}  // namespace
}  // namespace colmap
