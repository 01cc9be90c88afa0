#include "colmap_ext/exe/community_mapper.h"

#include "colmap_ext/util/atomic_output.h"
#include "colmap_ext/util/log_tag.h"

#include "colmap/controllers/option_manager.h"
#include "colmap/util/misc.h"

#include <fstream>
#include <sstream>

#include <boost/filesystem.hpp>
#include <sqlite3.h>

namespace colmap {
namespace {

// Checks the option values a user sets, with a message per problem.
bool CheckCommandOptions(const CommunityMapperController::Options& options) {
  bool valid = true;
  auto fail = [&valid](const std::string& message) {
    LOG(ERROR) << message;
    valid = false;
  };
  if (!(options.community_detection.modularity_threshold >= 0 &&
        options.community_detection.modularity_threshold < 1)) {
    fail(StringPrintf(
        "--CommunityMapper.modularity_threshold is %g: it must be in [0, 1) "
        "(the CSfM paper uses 0.3).",
        options.community_detection.modularity_threshold));
  }
  if (options.community_detection.min_community_size < 2) {
    fail(StringPrintf(
        "--CommunityMapper.min_community_size is %d: it must be at least 2 "
        "(the CSfM paper uses 20).",
        options.community_detection.min_community_size));
  }
  if (options.min_num_matches != -1 && options.min_num_matches < 1) {
    fail(StringPrintf(
        "--CommunityMapper.min_num_matches is %d: it must be positive, or -1 "
        "for --Mapper.min_num_matches.",
        options.min_num_matches));
  }
  if (options.edge_weights != "unit" && options.edge_weights != "num_inliers") {
    fail("--CommunityMapper.edge_weights is '" + options.edge_weights +
         "': use 'unit' or 'num_inliers'.");
  }
  if (options.image_overlap < 0) {
    fail(StringPrintf(
        "--CommunityMapper.image_overlap is %d: it must be 0 or more.",
        options.image_overlap));
  }
  if (options.num_workers == 0 || options.num_workers < -1) {
    fail(StringPrintf(
        "--CommunityMapper.num_workers is %d: it must be positive, or -1 for "
        "one per CPU core.",
        options.num_workers));
  }
  if (options.community_ba_function_tolerance != -1 &&
      options.community_ba_function_tolerance < 0) {
    fail(StringPrintf(
        "--CommunityMapper.community_ba_function_tolerance is %g: it must be "
        "0 or more, or -1 for --Mapper.ba_global_function_tolerance.",
        options.community_ba_function_tolerance));
  }
  if (options.community_ba_global_ratio != -1 &&
      !(options.community_ba_global_ratio > 1)) {
    fail(StringPrintf(
        "--CommunityMapper.community_ba_global_ratio is %g: it must be "
        "greater than 1, or -1 for --Mapper.ba_global_images_ratio and "
        "--Mapper.ba_global_points_ratio.",
        options.community_ba_global_ratio));
  }
  if (options.refinement.function_tolerance < 0) {
    fail(StringPrintf(
        "--CommunityMapper.ba_function_tolerance is %g: it must be 0 or more.",
        options.refinement.function_tolerance));
  }
  if (!(options.refinement.initial_trust_region_radius > 0)) {
    fail(StringPrintf(
        "--CommunityMapper.ba_initial_trust_region_radius is %g: it must be "
        "positive.",
        options.refinement.initial_trust_region_radius));
  }
  if (valid && !options.Check()) {
    fail("Invalid option values (see the check that failed above).");
  }
  return valid;
}

// Runs a query returning one integer; false if it fails.
bool QueryInteger(sqlite3* database, const std::string& sql, int64_t* value) {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(database, sql.c_str(), -1, &statement, nullptr) !=
      SQLITE_OK) {
    return false;
  }
  const bool ok = sqlite3_step(statement) == SQLITE_ROW;
  if (ok) {
    *value = sqlite3_column_int64(statement, 0);
  }
  sqlite3_finalize(statement);
  return ok;
}

// Reads the database without modifying it and says what it lacks.
bool CheckDatabase(const std::string& path, const int min_num_matches) {
  if (!ExistsFile(path)) {
    LOG(ERROR) << "The database " << path
               << " does not exist. Check --database_path, or create it with "
                  "`colmap feature_extractor` and a matcher (e.g. `colmap "
                  "exhaustive_matcher`).";
    return false;
  }
  sqlite3* database = nullptr;
  if (sqlite3_open_v2(path.c_str(), &database, SQLITE_OPEN_READONLY, nullptr) !=
      SQLITE_OK) {
    LOG(ERROR) << "Cannot open the database " << path << ": "
               << sqlite3_errmsg(database) << ".";
    sqlite3_close(database);
    return false;
  }
  struct Closer {
    sqlite3* database;
    ~Closer() { sqlite3_close(database); }
  } closer{database};

  int64_t num_tables = 0;
  if (!QueryInteger(database,
                    "SELECT COUNT(*) FROM sqlite_master WHERE type='table' AND "
                    "name IN ('images', 'keypoints', 'two_view_geometries')",
                    &num_tables)) {
    LOG(ERROR) << "Cannot read the database " << path << ": "
               << sqlite3_errmsg(database)
               << ". Is it a COLMAP database (e.g. from `colmap "
                  "feature_extractor`)?";
    return false;
  }
  if (num_tables != 3) {
    LOG(ERROR) << path
               << " is not a COLMAP database (it lacks the images, keypoints "
                  "or two_view_geometries table). Create it with `colmap "
                  "feature_extractor` and a matcher.";
    return false;
  }
  int64_t num_images = 0;
  int64_t num_keypoints = 0;
  int64_t num_pairs = 0;
  if (!QueryInteger(database, "SELECT COUNT(*) FROM images", &num_images) ||
      !QueryInteger(database,
                    "SELECT COUNT(*) FROM keypoints WHERE rows > 0",
                    &num_keypoints) ||
      !QueryInteger(database,
                    "SELECT COUNT(*) FROM two_view_geometries WHERE rows >= " +
                        std::to_string(min_num_matches),
                    &num_pairs)) {
    LOG(ERROR) << "Cannot read the database " << path << ": "
               << sqlite3_errmsg(database) << ".";
    return false;
  }
  if (num_images == 0) {
    LOG(ERROR) << "The database " << path
               << " has no images: run `colmap feature_extractor` on your "
                  "images first, then a matcher. (If you did, it could read "
                  "none of them: check its --image_path and the image "
                  "files.)";
    return false;
  }
  if (num_keypoints == 0) {
    LOG(ERROR) << "The database " << path << " has " << num_images
               << " images but no features: run `colmap feature_extractor` "
                  "(check that it can read the images), then a matcher.";
    return false;
  }
  if (num_pairs == 0) {
    LOG(ERROR) << "The database " << path
               << " has no verified image pairs with at least "
               << min_num_matches
               << " inlier matches: run a matcher first (e.g. `colmap "
                  "exhaustive_matcher`, `sequential_matcher` or "
                  "`vocab_tree_matcher`).";
    return false;
  }
  return true;
}

// Warns if the image folder has no files: the images are only read for the
// points' colours.
void CheckImagePath(const std::string& image_path) {
  if (!ExistsDir(image_path)) {
    LOG(WARNING) << "--image_path " << image_path
                 << " is not a folder: the points will have no colours.";
    return;
  }
  boost::system::error_code error;
  if (boost::filesystem::is_empty(image_path, error) && !error) {
    LOG(WARNING) << "--image_path " << image_path
                 << " is empty: the points will have no colours.";
  }
}

// The numbered model folders in OUT (0, 1, ...).
std::vector<std::string> ExistingModels(const std::string& output_path) {
  std::vector<std::string> models;
  for (int i = 0; ExistsDir(JoinPaths(output_path, std::to_string(i))); ++i) {
    if (IsModelDir(JoinPaths(output_path, std::to_string(i)))) {
      models.push_back(JoinPaths(output_path, std::to_string(i)));
    }
  }
  return models;
}

// Makes sure OUT is a writable folder without earlier results (unless they
// may be replaced).
bool PrepareOutputPath(const std::string& output_path, const bool overwrite) {
  if (output_path.empty()) {
    LOG(ERROR) << "--output_path is empty.";
    return false;
  }
  if (boost::filesystem::exists(output_path) && !ExistsDir(output_path)) {
    LOG(ERROR) << "--output_path " << output_path
               << " is a file, not a folder: choose a folder for the models.";
    return false;
  }
  boost::system::error_code error;
  boost::filesystem::create_directories(output_path, error);
  if (error) {
    LOG(ERROR) << "Cannot create --output_path " << output_path << ": "
               << error.message() << ".";
    return false;
  }
  const std::string probe = JoinPaths(output_path, ".write-test");
  {
    std::ofstream file(probe);
    if (!file.is_open() || !(file << "x")) {
      LOG(ERROR) << "--output_path " << output_path
                 << " is not writable: choose a folder you can write to.";
      return false;
    }
  }
  boost::filesystem::remove(probe, error);

  const std::vector<std::string> models = ExistingModels(output_path);
  const bool has_results =
      !models.empty() ||
      ExistsFile(JoinPaths(output_path, "communities.txt")) ||
      ExistsDir(JoinPaths(output_path, "communities"));
  if (has_results && !overwrite) {
    LOG(ERROR) << "--output_path " << output_path
               << " already holds results of an earlier run"
               << (models.empty() ? "" : " (e.g. " + models[0] + ")")
               << ". Choose another folder, or pass "
                  "--CommunityMapper.overwrite 1 to replace them.";
    return false;
  }
  if (has_results) {
    LOG(WARNING) << "Replacing the results in " << output_path
                 << " (--CommunityMapper.overwrite 1)";
    boost::filesystem::remove_all(JoinPaths(output_path, "communities"));
  }
  return true;
}

// Writes the merged models as OUT/0, OUT/1, ... (each under a temporary name,
// then renamed into place), removes models of an earlier run beyond them,
// and writes OUT/project.ini.
void WriteModels(const ReconstructionManager& reconstruction_manager,
                 const std::string& output_path,
                 const std::string& project_ini) {
  for (size_t i = 0; i < reconstruction_manager.Size(); ++i) {
    WriteReconstructionAtomically(*reconstruction_manager.Get(i),
                                  JoinPaths(output_path, std::to_string(i)));
  }
  // Models of an earlier run beyond the new ones would mix with them.
  for (size_t i = reconstruction_manager.Size();
       ExistsDir(JoinPaths(output_path, std::to_string(i)));
       ++i) {
    boost::filesystem::remove_all(JoinPaths(output_path, std::to_string(i)));
  }
  if (!project_ini.empty()) {
    WriteTextFileAtomically(project_ini, JoinPaths(output_path, "project.ini"));
  }
}

}  // namespace

bool RunCommunityMapperImpl(const CommunityMapperController::Options& options,
                            const bool overwrite,
                            const std::string& project_ini) {
  if (!CheckCommandOptions(options) ||
      !CheckDatabase(options.database_path, options.MinNumMatches()) ||
      !PrepareOutputPath(options.output_path, overwrite)) {
    return false;
  }
  if (!options.partition_only) {
    CheckImagePath(options.image_path);
  }

  auto reconstruction_manager = std::make_shared<ReconstructionManager>();
  CommunityMapperController::Summary summary;
  try {
    CommunityMapperController controller(options, reconstruction_manager);
    controller.Run();
    summary = controller.GetSummary();
  } catch (const std::exception& error) {
    LOG(ERROR) << "community_mapper failed: " << error.what();
    return false;
  }
  if (summary.community_sizes.empty()) {
    LOG(ERROR) << "No communities: the view graph is empty.";
    return false;
  }

  const std::string& output_path = options.output_path;
  std::vector<std::string> outputs = {
      JoinPaths(output_path, "communities.txt") + " (the partition)"};
  if (options.partition_only && overwrite) {
    // The merged models of an earlier run (allowed to be replaced) do not
    // belong to the new partition.
    boost::system::error_code error;
    for (const std::string& model : ExistingModels(output_path)) {
      LOG(INFO) << "Removing " << model << " of an earlier run";
      boost::filesystem::remove_all(model, error);
    }
    boost::filesystem::remove(JoinPaths(output_path, "communities.ply"), error);
  }
  if (!options.partition_only) {
    if (reconstruction_manager->Size() == 0) {
      LOG(ERROR) << "No community could be reconstructed: no model written.";
      return false;
    }
    try {
      WriteModels(*reconstruction_manager, output_path, project_ini);
    } catch (const std::exception& error) {
      LOG(ERROR) << "Writing the models to " << output_path
                 << " failed: " << error.what()
                 << ". No model folder is half-written, but those after the "
                    "failed one may still be an earlier run's; check the free "
                    "space and permissions, then run again.";
      return false;
    }
    outputs.push_back(
        JoinPaths(output_path, "0") +
        (reconstruction_manager->Size() > 1
             ? " .. " + std::to_string(reconstruction_manager->Size() - 1)
             : std::string()) +
        " (the merged model" + (reconstruction_manager->Size() > 1 ? "s" : "") +
        ", largest first)");
    outputs.push_back(JoinPaths(output_path, "communities", "K") +
                      " (each community's own model)");
    outputs.push_back(JoinPaths(output_path, "communities.ply") +
                      " (camera centres of model 0, coloured by community)");
    if (!project_ini.empty()) {
      outputs.push_back(JoinPaths(output_path, "project.ini"));
    }
  }
  LOG(INFO) << "Results:";
  for (const std::string& output : outputs) {
    LOG(INFO) << "  " << output;
  }
  return true;
}

int RunCommunityMapper(int argc, char** argv) {
  InstallTaggedLogPrefix("colmap");

  CommunityMapperController::Options mapper_options;
  std::string output_path;
  bool overwrite = false;

  OptionManager options;
  options.AddDatabaseOptions();
  options.AddImageOptions();
  options.AddRequiredOption("output_path", &output_path);

  // Every CommunityMapper option, registered once for parsing and for
  // project.ini.
  std::ostringstream ini_section;
  ini_section << "[CommunityMapper]\n";
  std::vector<std::function<void()>> ini_writers;
  auto add = [&](const std::string& name, auto* value, const char* help) {
    options.AddDefaultOption("CommunityMapper." + name, value, help);
    ini_writers.push_back([&ini_section, name, value] {
      ini_section << name << "=" << *value << "\n";
    });
  };
  add("modularity_threshold",
      &mapper_options.community_detection.modularity_threshold,
      "split a view (sub)graph only where its peak modularity Qmax exceeds "
      "this");
  add("min_community_size",
      &mapper_options.community_detection.min_community_size,
      "communities with fewer images are merged into their most connected "
      "neighbour");
  add("max_community_fraction",
      &mapper_options.community_detection.max_community_fraction,
      "a (sub)graph holding more than this fraction of its connected "
      "component is split at its modularity peak even below the threshold, "
      "so that no community sets the pace alone (1: threshold only)");
  add("min_num_matches",
      &mapper_options.min_num_matches,
      "minimum verified inliers of a view-graph edge (-1: "
      "Mapper.min_num_matches)");
  add("edge_weights",
      &mapper_options.edge_weights,
      "edge weights for community detection: unit | num_inliers (use "
      "num_inliers after exhaustive matching)");
  add("image_overlap",
      &mapper_options.image_overlap,
      "images each community borrows from each neighbouring community, so "
      "that their models share points (0: no sharing, as in the paper)");
  add("partition_only",
      &mapper_options.partition_only,
      "stop after writing communities.txt");
  add("num_workers",
      &mapper_options.num_workers,
      "communities reconstructed at once (-1: one per CPU core)");
  add("community_ba_function_tolerance",
      &mapper_options.community_ba_function_tolerance,
      "relative function tolerance of the communities' global bundle "
      "adjustments (-1: Mapper.ba_global_function_tolerance)");
  add("community_ba_global_ratio",
      &mapper_options.community_ba_global_ratio,
      "growth of a community's model (images or points) after which it is "
      "bundle adjusted as a whole (-1: Mapper.ba_global_images_ratio and "
      "Mapper.ba_global_points_ratio)");
  add("pairwise_max_relative_error",
      &mapper_options.pairwise_similarity.max_relative_error,
      "similarity RANSAC inlier threshold, relative to the spread of the "
      "co-visible points");
  add("pairwise_min_num_inliers",
      &mapper_options.pairwise_similarity.min_num_inliers,
      "minimum inlier correspondences of a pairwise similarity");
  add("pairwise_max_num_hypotheses",
      &mapper_options.pairwise_similarity.max_num_hypotheses,
      "similarities tried per community pair when the co-visibility check "
      "rejects one (each next from the outliers of those before)");
  add("covisibility_min_rate_ratio",
      &mapper_options.covisibility_check.min_rate_ratio,
      "reject a similarity under which the image pairs it makes co-visible "
      "across the communities were verified less often than this fraction of "
      "the rate inside them (0: no check)");
  add("max_rotation_residual_deg",
      &mapper_options.similarity_averaging.max_rotation_residual_deg,
      "drop a pairwise similarity whose rotation residual after averaging "
      "exceeds this");
  add("max_log_scale_residual",
      &mapper_options.similarity_averaging.max_log_scale_residual,
      "drop a pairwise similarity whose log scale residual after averaging "
      "exceeds this");
  add("max_relative_translation_residual",
      &mapper_options.similarity_averaging.max_relative_translation_residual,
      "drop a pairwise similarity whose translation residual after averaging, "
      "relative to its points' spread, exceeds this");
  add("min_registered_fraction",
      &mapper_options.judgement.min_registered_fraction,
      "a community whose model registered fewer of its images than this "
      "fraction (of the communities' median fraction) is in doubt");
  add("max_relative_reprojection_error",
      &mapper_options.judgement.max_relative_reprojection_error,
      "a community whose model's mean reprojection error exceeds this many "
      "times the communities' median is in doubt");
  add("register_remaining_images",
      &mapper_options.refinement.register_remaining_images,
      "try to register, in the merged model, images no community registered");
  add("robust_first_adjustment",
      &mapper_options.refinement.robust_first_adjustment,
      "align the merged model's cameras under a robust loss");
  add("alignment_max_points_per_image",
      &mapper_options.refinement.alignment_max_points_per_image,
      "points per image (longest tracks first) in the merged model's first "
      "bundle adjustment, which aligns the communities' cameras before all "
      "points are triangulated anew");
  add("ba_function_tolerance",
      &mapper_options.refinement.function_tolerance,
      "the merged model's bundle adjustments stop once an iteration lowers "
      "the cost by less than this fraction");
  add("ba_initial_trust_region_radius",
      &mapper_options.refinement.initial_trust_region_radius,
      "initial Levenberg-Marquardt trust region radius of the merged model's "
      "bundle adjustments");
  add("sparse_solver",
      &mapper_options.refinement.sparse_solver,
      "use the sparse direct solver in the merged model's bundle adjustment "
      "at any size (COLMAP switches to the iterative one above 1000 images)");
  // Not saved to project.ini: a saved project must not replace results.
  options.AddDefaultOption("CommunityMapper.overwrite",
                           &overwrite,
                           "replace the results of an earlier run in "
                           "output_path");
  options.AddMapperOptions();
  options.Parse(argc, argv);

  mapper_options.database_path = *options.database_path;
  mapper_options.image_path = *options.image_path;
  mapper_options.output_path = output_path;
  mapper_options.incremental_options = *options.mapper;

  // project.ini: COLMAP's options, then the CommunityMapper section.
  std::string project_ini;
  {
    const boost::filesystem::path temporary =
        boost::filesystem::temp_directory_path() /
        boost::filesystem::unique_path("community_mapper-%%%%%%%%.ini");
    options.Write(temporary.string());
    std::ifstream file(temporary.string());
    std::stringstream text;
    text << file.rdbuf();
    boost::filesystem::remove(temporary);
    for (const auto& write : ini_writers) {
      write();
    }
    // output_path first: options outside any section precede the sections.
    project_ini =
        "output_path=" + output_path + "\n" + text.str() + ini_section.str();
  }

  return RunCommunityMapperImpl(mapper_options, overwrite, project_ini)
             ? EXIT_SUCCESS
             : EXIT_FAILURE;
}

}  // namespace colmap
