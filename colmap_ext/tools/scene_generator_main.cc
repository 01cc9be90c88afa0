// scene_generator: writes a generated scene with community structure (see
// colmap_ext/testing/synthetic_scene.h) as a COLMAP project:
//
//   OUT/database.db     rigs, cameras, frames, images, keypoints, raw
//                       matches and the two-view geometries COLMAP's own
//                       geometric verification estimates from them, as
//                       COLMAP's extractor and matcher write them (and
//                       rig_configurator, with --num_rig_cameras > 1)
//   OUT/images/         empty: there are no photos, mappers only warn
//   OUT/ground_truth/   the true rigs, cameras, frames, images and points
//                       (binary model)
//   OUT/clusters.txt    IMAGE_NAME CLUSTER, -1 for walkway images
//
//   scene_generator --output_path OUT --num_clusters 3 --seed 1 ...

#include "colmap_ext/testing/synthetic_scene.h"

#include "colmap/controllers/option_manager.h"
#include "colmap/scene/database.h"
#include "colmap/util/file.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"

#include <filesystem>

namespace colmap {
namespace {

int RunSceneGenerator(int argc, char** argv) {
  std::string output_path;
  bool overwrite = false;
  SyntheticSceneOptions scene_options;
  int seed = 0;

  OptionManager options(/*add_project_options=*/false);
  options.AddRequiredOption("output_path", &output_path);
  options.AddDefaultOption("overwrite", &overwrite);
  options.AddDefaultOption("num_clusters", &scene_options.num_clusters);
  options.AddDefaultOption("num_images_per_cluster",
                           &scene_options.num_images_per_cluster);
  options.AddDefaultOption("num_images_per_link",
                           &scene_options.num_images_per_link);
  options.AddDefaultOption("close_loop", &scene_options.close_loop);
  options.AddDefaultOption("landmark_spacing", &scene_options.landmark_spacing);
  options.AddDefaultOption("num_points_per_cluster",
                           &scene_options.num_points_per_cluster);
  options.AddDefaultOption("num_points_per_link",
                           &scene_options.num_points_per_link);
  options.AddDefaultOption("image_width", &scene_options.image_width);
  options.AddDefaultOption("image_height", &scene_options.image_height);
  options.AddDefaultOption("focal_length", &scene_options.focal_length);
  options.AddDefaultOption("single_camera", &scene_options.single_camera);
  options.AddDefaultOption("num_rig_cameras", &scene_options.num_rig_cameras);
  options.AddDefaultOption("rig_baseline", &scene_options.rig_baseline);
  options.AddDefaultOption("rig_yaw_deg", &scene_options.rig_yaw_deg);
  options.AddDefaultOption("focal_length_noise",
                           &scene_options.focal_length_noise);
  options.AddDefaultOption("keypoint_noise", &scene_options.keypoint_noise);
  options.AddDefaultOption("num_distractor_keypoints",
                           &scene_options.num_distractor_keypoints);
  options.AddDefaultOption("max_viewing_distance",
                           &scene_options.max_viewing_distance);
  options.AddDefaultOption("min_num_shared_points",
                           &scene_options.min_num_shared_points);
  options.AddDefaultOption("wrong_match_fraction",
                           &scene_options.wrong_match_fraction);
  options.AddDefaultOption("epipolar_wrong_match_share",
                           &scene_options.epipolar_wrong_match_share);
  options.AddDefaultOption("num_false_pairs", &scene_options.num_false_pairs);
  options.AddDefaultOption("false_pair_num_matches",
                           &scene_options.false_pair_num_matches);
  options.AddDefaultOption("num_repeated_structure_pairs",
                           &scene_options.num_repeated_structure_pairs);
  options.AddDefaultOption("num_repeated_texture_pairs",
                           &scene_options.num_repeated_texture_pairs);
  options.AddDefaultOption("num_threads", &scene_options.num_threads);
  options.AddDefaultOption("seed", &seed);
  if (!options.Parse(argc, argv)) {
    return EXIT_FAILURE;
  }
  scene_options.seed = static_cast<unsigned int>(seed);

  if (!scene_options.Check()) {
    LOG(ERROR) << "Invalid scene options.";
    return EXIT_FAILURE;
  }

  const std::filesystem::path database_path =
      std::filesystem::path(output_path) / "database.db";
  const std::filesystem::path ground_truth_path =
      std::filesystem::path(output_path) / "ground_truth";
  if (ExistsFile(database_path)) {
    if (!overwrite) {
      LOG(ERROR) << database_path.string()
                 << " exists: choose another --output_path or pass "
                    "--overwrite 1.";
      return EXIT_FAILURE;
    }
    for (const std::string suffix : {"", "-wal", "-shm"}) {
      std::filesystem::remove(database_path.string() + suffix);
    }
    std::filesystem::remove_all(ground_truth_path);
  }
  CreateDirIfNotExists(output_path, /*recursive=*/true);
  CreateDirIfNotExists(std::filesystem::path(output_path) / "images");
  CreateDirIfNotExists(ground_truth_path);

  Timer timer;
  timer.Start();
  SyntheticScene scene;
  {
    const std::shared_ptr<Database> database = Database::Open(database_path);
    SynthesizeCommunityScene(scene_options, &scene, database.get());
  }
  scene.ground_truth.Write(ground_truth_path);
  WriteImageClusters(
      scene, (std::filesystem::path(output_path) / "clusters.txt").string());

  LOG(INFO) << StringPrintf(
      "Generated %d images (%d clusters of %d, %d per walkway), %d points; "
      "%d matched pairs (%d by chance, %d on repeated structure, %d on "
      "repeated texture), %d verified, %zu of %zu raw matches inliers, in "
      "%.1fs -> %s",
      static_cast<int>(scene.ground_truth.NumRegImages()),
      scene_options.num_clusters,
      scene_options.num_images_per_cluster,
      scene_options.num_images_per_link,
      static_cast<int>(scene.ground_truth.NumPoints3D()),
      scene.num_matched_pairs,
      scene.num_false_pairs,
      scene.num_repeated_structure_pairs,
      scene.num_repeated_texture_pairs,
      scene.num_verified_pairs,
      scene.num_inlier_matches,
      scene.num_raw_matches,
      timer.ElapsedSeconds(),
      output_path.c_str());
  return EXIT_SUCCESS;
}

}  // namespace
}  // namespace colmap

int main(int argc, char** argv) {
  colmap::InitializeGlog(argv);
  return colmap::RunSceneGenerator(argc, argv);
}
