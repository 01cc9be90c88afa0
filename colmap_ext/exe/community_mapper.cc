#include "colmap_ext/exe/community_mapper.h"

#include "colmap_ext/scene/community_io.h"
#include "colmap_ext/scene/community_workspace.h"
#include "colmap_ext/util/atomic_output.h"
#include "colmap_ext/util/log_tag.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/controllers/option_manager.h"
#include "colmap/util/misc.h"

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include <boost/filesystem.hpp>
#include <sqlite3.h>

namespace colmap {
namespace {

// Checks the option values a user sets, with a message per problem.
bool CheckCommandOptions(const CommunityMapperCommand& command) {
  const CommunityMapperController::Options& options = command.options;
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
  if (!(options.community_detection.max_community_fraction > 0 &&
        options.community_detection.max_community_fraction <= 1)) {
    fail(StringPrintf(
        "--CommunityMapper.max_community_fraction is %g: it must be in (0, 1] "
        "(1: split by the threshold only).",
        options.community_detection.max_community_fraction));
  }
  if (!(options.community_detection.max_part_conductance > 0 &&
        options.community_detection.max_part_conductance <= 1)) {
    fail(StringPrintf(
        "--CommunityMapper.max_part_conductance is %g: it must be in (0, 1] "
        "(1: split by the threshold only).",
        options.community_detection.max_part_conductance));
  }
  if (!(options.community_detection.max_joined_part_fraction >= 0 &&
        options.community_detection.max_joined_part_fraction < 1)) {
    fail(StringPrintf(
        "--CommunityMapper.max_joined_part_fraction is %g: it must be in "
        "[0, 1).",
        options.community_detection.max_joined_part_fraction));
  }
  if (options.min_num_matches != -1 && options.min_num_matches < 1) {
    fail(StringPrintf(
        "--CommunityMapper.min_num_matches is %d: it must be positive, or -1 "
        "for --Mapper.min_num_matches.",
        options.min_num_matches));
  }
  if (command.edge_weights != "unit" && command.edge_weights != "num_inliers") {
    fail("--CommunityMapper.edge_weights is '" + command.edge_weights +
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
  if (!(options.refinement.triangulation_filter_factor >= 0)) {
    fail(StringPrintf(
        "--CommunityMapper.triangulation_filter_factor is %g: it must be 0 "
        "or more.",
        options.refinement.triangulation_filter_factor));
  }
  if (!(options.refinement.final_filter_noise_multiple >= 0)) {
    fail(StringPrintf(
        "--CommunityMapper.final_filter_noise_multiple is %g: it must be 0 "
        "(off) or more.",
        options.refinement.final_filter_noise_multiple));
  }
  if (!(options.refinement.max_refinement_change == -1 ||
        options.refinement.max_refinement_change >= 0)) {
    fail(StringPrintf(
        "--CommunityMapper.max_refinement_change is %g: it must be 0 or "
        "more, or -1 for --Mapper.ba_global_max_refinement_change.",
        options.refinement.max_refinement_change));
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
  if (!(options.refinement.max_selected_observation_fraction >= 0 &&
        options.refinement.max_selected_observation_fraction <= 1)) {
    fail(StringPrintf(
        "--CommunityMapper.ba_max_selected_fraction is %g: it must be "
        "between 0 and 1.",
        options.refinement.max_selected_observation_fraction));
  }
  if (options.refinement.track_selection.grid_size < 1 ||
      options.refinement.track_selection.min_tracks_per_image < 0) {
    fail(StringPrintf(
        "--CommunityMapper.ba_track_grid_size (%d) must be positive and "
        "--CommunityMapper.ba_min_tracks_per_image (%d) 0 or more; "
        "--CommunityMapper.reduced_adjustment 0 adjusts over all tracks.",
        options.refinement.track_selection.grid_size,
        options.refinement.track_selection.min_tracks_per_image));
  }
  if (options.pose_graph.min_num_shared_points < 1 ||
      options.pose_graph.max_num_neighbors < 1) {
    fail(StringPrintf(
        "--CommunityMapper.pose_graph_min_num_shared_points (%d) and "
        "--CommunityMapper.pose_graph_max_num_neighbors (%d) must be "
        "positive; --CommunityMapper.pose_graph_alignment 0 turns the pose "
        "graph off.",
        options.pose_graph.min_num_shared_points,
        options.pose_graph.max_num_neighbors));
  }
  if (!(options.refinement.block_registration.min_inlier_fraction >= 0 &&
        options.refinement.block_registration.min_inlier_fraction <= 1)) {
    fail(StringPrintf(
        "--CommunityMapper.block_min_inlier_fraction (%g) must be within "
        "[0, 1].",
        options.refinement.block_registration.min_inlier_fraction));
  }
  if (options.refinement.block_registration.min_num_shared_images < 1) {
    fail(StringPrintf(
        "--CommunityMapper.block_min_num_shared_images (%d) must be "
        "positive; --CommunityMapper.register_offered_blocks 0 registers "
        "offered communities image by image.",
        options.refinement.block_registration.min_num_shared_images));
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

// Reads --image_list_path into options->image_names, each name an image of
// the database, and records the list in the plan's options (a plan made
// with another list does not fit). False, with the reason logged, if the
// file is missing or empty or names an image the database lacks.
bool ReadImageListIntoOptions(const std::string& path,
                              CommunityMapperController::Options* options) {
  std::vector<std::string> names;
  const std::string problem = ReadImageList(path, &names);
  if (!problem.empty()) {
    LOG(ERROR) << problem;
    return false;
  }
  const Database database(options->database_path);
  std::vector<std::string> unknown;
  for (const std::string& name : names) {
    if (!database.ExistsImageWithName(name)) {
      unknown.push_back(name);
    }
  }
  if (!unknown.empty()) {
    LOG(ERROR) << StringPrintf(
        "%d of the %d names in the image list %s are no image of the "
        "database %s, e.g. '%s'. Names are as in the database (relative to "
        "the image folder, e.g. 'dir/image.jpg').",
        static_cast<int>(unknown.size()),
        static_cast<int>(names.size()),
        path.c_str(),
        options->database_path.c_str(),
        unknown.front().c_str());
    return false;
  }
  options->image_names.insert(names.begin(), names.end());
  options->plan_options += StringPrintf("image_list_path=%d images, list %s\n",
                                        static_cast<int>(names.size()),
                                        TextsFingerprint(names).c_str());
  return true;
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

// The options that shape the partition and the communities' models, as
// "key=value" lines of project.ini: every incremental mapper option but its
// threads and snapshots, and the CommunityMapper options below. The plan
// records them; the later stages refuse a plan made with others. The merge's
// own options may differ between merges of the same communities.
std::string PlanOptions(const std::string& project_ini) {
  static const std::set<std::string> kCommunityMapperKeys = {
      "modularity_threshold",
      "min_community_size",
      "max_community_fraction",
      "max_part_conductance",
      "max_joined_part_fraction",
      "min_num_matches",
      "edge_weights",
      "image_overlap",
      "community_ba_function_tolerance",
      "community_ba_global_ratio",
      "mapper_schedule_for_own_cameras"};
  static const std::set<std::string> kIgnoredMapperKeys = {
      "num_threads", "snapshot_path", "snapshot_images_freq"};
  std::string plan_options;
  std::string section;
  std::istringstream lines(project_ini);
  std::string line;
  while (std::getline(lines, line)) {
    if (!line.empty() && line[0] == '[') {
      section = line.substr(1, line.find(']') - 1);
      continue;
    }
    const size_t equals = line.find('=');
    if (equals == std::string::npos) {
      continue;
    }
    const std::string key = line.substr(0, equals);
    if ((section == "Mapper" && kIgnoredMapperKeys.count(key) == 0) ||
        (section == "CommunityMapper" && kCommunityMapperKeys.count(key))) {
      plan_options += section + "." + line + "\n";
    }
  }
  return plan_options;
}

const char* StageName(const CommunityMapperStage stage) {
  switch (stage) {
    case CommunityMapperStage::kAll:
      return "community_mapper";
    case CommunityMapperStage::kPartition:
      return "community_partitioner";
    case CommunityMapperStage::kCommunity:
      return "community_reconstructor";
    case CommunityMapperStage::kMerge:
      return "community_merger";
  }
  return "";
}

// Decides what the command may do with the results already in OUT: resume
// them (a plan of the same database and options: the controller checks
// that), replace them (--CommunityMapper.overwrite 1), or nothing (refused).
bool PrepareWorkspace(const CommunityMapperCommand& command,
                      const CommunityWorkspace& workspace) {
  const bool has_plan = ExistsFile(workspace.PlanPath());
  if ((command.stage == CommunityMapperStage::kCommunity ||
       command.stage == CommunityMapperStage::kMerge) &&
      !has_plan) {
    LOG(ERROR) << workspace.PlanPath()
               << " does not exist: run `colmap community_partitioner` with "
                  "this --output_path first.";
    return false;
  }
  const std::string problem = workspace.CreateOutputFolder();
  if (!problem.empty()) {
    LOG(ERROR) << problem;
    return false;
  }
  switch (command.stage) {
    case CommunityMapperStage::kAll:
    case CommunityMapperStage::kPartition:
      if (command.overwrite) {
        if (workspace.HasResults()) {
          LOG(WARNING) << "Replacing the results in " << workspace.OutputPath()
                       << " (--CommunityMapper.overwrite 1)";
          workspace.RemoveResults();
        }
      } else if (!has_plan && workspace.HasResults()) {
        const std::vector<std::string> models = workspace.MergedModelPaths();
        LOG(ERROR) << "--output_path " << workspace.OutputPath()
                   << " already holds results of an earlier run"
                   << (models.empty() ? "" : " (e.g. " + models[0] + ")")
                   << " but no plan to resume. Choose another folder, or "
                      "pass --CommunityMapper.overwrite 1 to replace them.";
        return false;
      }
      return true;
    case CommunityMapperStage::kCommunity:
    case CommunityMapperStage::kMerge:
      return true;
  }
  return false;
}

}  // namespace

bool RunCommunityMapperImpl(const CommunityMapperCommand& command) {
  if (!CheckCommandOptions(command)) {
    return false;
  }
  CommunityMapperController::Options options = command.options;
  options.edge_weight = ViewGraphEdgeWeightFromString(command.edge_weights);
  const CommunityWorkspace workspace(options.output_path);
  if (!CheckDatabase(options.database_path, options.MinNumMatches()) ||
      (!command.image_list_path.empty() &&
       !ReadImageListIntoOptions(command.image_list_path, &options)) ||
      !PrepareWorkspace(command, workspace)) {
    return false;
  }
  if (command.stage == CommunityMapperStage::kCommunity &&
      command.community_id < 0) {
    LOG(ERROR) << "--community_id is missing or negative: give the community "
                  "to reconstruct, 0 to N-1 for the N communities in "
               << workspace.PlanPath() << ".";
    return false;
  }
  const bool merges = command.stage == CommunityMapperStage::kAll ||
                      command.stage == CommunityMapperStage::kMerge;
  if (merges && !options.partition_only) {
    CheckImagePath(options.image_path);
  }

  auto reconstruction_manager = std::make_shared<ReconstructionManager>();
  CommunityMapperController::Summary summary;
  try {
    CommunityMapperController controller(options, reconstruction_manager);
    bool success = true;
    switch (command.stage) {
      case CommunityMapperStage::kAll:
        success = controller.RunAllStages();
        break;
      case CommunityMapperStage::kPartition:
        success = controller.Partition();
        break;
      case CommunityMapperStage::kCommunity:
        if (command.overwrite) {
          workspace.RemoveCommunity(command.community_id);
        }
        success = controller.ReconstructCommunity(command.community_id);
        break;
      case CommunityMapperStage::kMerge:
        success = controller.Merge();
        break;
    }
    if (!success) {
      return false;
    }
    summary = controller.GetSummary();
  } catch (const std::exception& error) {
    LOG(ERROR) << StageName(command.stage) << " failed: " << error.what();
    return false;
  }

  std::vector<std::string> outputs;
  try {
    if (command.stage == CommunityMapperStage::kPartition ||
        (command.stage == CommunityMapperStage::kAll &&
         !ExistsFile(workspace.ProjectPath()))) {
      if (!command.project_ini.empty()) {
        WriteTextFileAtomically(command.project_ini, workspace.ProjectPath());
      }
    }
    if (command.stage == CommunityMapperStage::kPartition ||
        (command.stage == CommunityMapperStage::kAll &&
         options.partition_only)) {
      outputs.push_back(workspace.CommunitiesPath() + " (the partition)");
      outputs.push_back(workspace.PlanPath() +
                        " (what the community and merge stages read)");
    } else if (command.stage == CommunityMapperStage::kCommunity) {
      outputs.push_back(workspace.CommunityModelPath(command.community_id) +
                        " (the community's model) and its record " +
                        workspace.CommunityRecordPath(command.community_id));
    } else {
      std::vector<std::shared_ptr<const Reconstruction>> models;
      for (size_t i = 0; i < reconstruction_manager->Size(); ++i) {
        models.push_back(reconstruction_manager->Get(i));
      }
      workspace.WriteMergedModels(models);
      if (!command.project_ini.empty()) {
        WriteTextFileAtomically(command.project_ini, workspace.ProjectPath());
      }
      WriteTextFileAtomically(CommunityMapperController::SummaryToText(summary),
                              workspace.SummaryPath());
      outputs.push_back(workspace.MergedModelPath(0) +
                        (models.size() > 1
                             ? " .. " + std::to_string(models.size() - 1)
                             : std::string()) +
                        " (the merged model" + (models.size() > 1 ? "s" : "") +
                        ", largest first)");
      outputs.push_back(JoinPaths(workspace.CommunitiesDir(), "K") +
                        " (each community's own model)");
      outputs.push_back(workspace.CommunitiesPlyPath() +
                        " (camera centres of model 0, coloured by community)");
      outputs.push_back(workspace.ProjectPath());
      outputs.push_back(workspace.SummaryPath() +
                        " (figures of the run: phases, memory, models)");
    }
  } catch (const std::exception& error) {
    LOG(ERROR) << "Writing to " << workspace.OutputPath()
               << " failed: " << error.what()
               << ". No file or model folder is half-written; check the free "
                  "space and permissions, then run the same command again "
                  "(it resumes).";
    return false;
  }
  LOG(INFO) << "Results:";
  for (const std::string& output : outputs) {
    LOG(INFO) << "  " << output;
  }
  return true;
}

namespace {

// Parses the command line of `stage`'s command into `command` (exits on
// --help or unparsable options, as every COLMAP command does).
void ParseCommand(int argc,
                  char** argv,
                  const CommunityMapperStage stage,
                  CommunityMapperCommand* command) {
  InstallTaggedLogPrefix("colmap");
  command->stage = stage;
  CommunityMapperController::Options& mapper_options = command->options;
  std::string output_path;

  // --community_id is taken from the command line even with --project_path
  // (whose options replace the command line's in COLMAP's OptionManager), so
  // that the jobs of an array share one project file.
  std::vector<char*> arguments(argv, argv + argc);
  if (stage == CommunityMapperStage::kCommunity) {
    for (size_t i = 1; i < arguments.size(); ++i) {
      const std::string argument = arguments[i];
      std::string value;
      if (argument == "--community_id" && i + 1 < arguments.size()) {
        value = arguments[i + 1];
        arguments.erase(arguments.begin() + i, arguments.begin() + i + 2);
      } else if (argument.rfind("--community_id=", 0) == 0) {
        value = argument.substr(15);
        arguments.erase(arguments.begin() + i);
      } else {
        continue;
      }
      try {
        size_t end = 0;
        command->community_id = std::stoi(value, &end);
        if (end != value.size()) throw std::invalid_argument(value);
      } catch (const std::logic_error&) {
        LOG(ERROR) << "--community_id " << value << " is not a number.";
        std::exit(EXIT_FAILURE);
      }
      break;
    }
  }

  // With --project_path, COLMAP's OptionManager reads every option from the
  // file and silently drops the command line's: refuse them instead, so that
  // nobody merges again believing an option changed.
  bool has_project_path = false;
  std::string dropped_options;
  for (size_t i = 1; i < arguments.size(); ++i) {
    const std::string argument = arguments[i];
    if (argument == "--project_path") {
      has_project_path = true;
      ++i;
    } else if (argument.rfind("--project_path=", 0) == 0) {
      has_project_path = true;
    } else if (argument.rfind("--", 0) == 0) {
      dropped_options += (dropped_options.empty() ? "" : ", ") +
                         argument.substr(0, argument.find('='));
    }
  }
  if (has_project_path && !dropped_options.empty()) {
    LOG(ERROR) << "With --project_path every option is read from that file; "
               << dropped_options
               << " on the command line would be ignored. Change it in the "
                  "project file (e.g. OUT/project.ini), or give the options "
                  "without --project_path.";
    std::exit(EXIT_FAILURE);
  }

  OptionManager options;
  options.AddDatabaseOptions();
  options.AddImageOptions();
  options.AddRequiredOption("output_path", &output_path);
  options.AddDefaultOption("image_list_path",
                           &command->image_list_path,
                           "reconstruct only the images named in this file, "
                           "one per line, as colmap mapper");
  int community_id_for_help = -1;
  if (stage == CommunityMapperStage::kCommunity) {
    options.AddDefaultOption("community_id",
                             &community_id_for_help,
                             "the community to reconstruct (0 to N-1, N in "
                             "OUT/plan.txt; on Slurm: $SLURM_ARRAY_TASK_ID)");
  }

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
  add("max_part_conductance",
      &mapper_options.community_detection.max_part_conductance,
      "a split by the threshold is refused where a part has more than this "
      "share of its edges to the other parts (1: threshold only)");
  add("max_joined_part_fraction",
      &mapper_options.community_detection.max_joined_part_fraction,
      "such a part holding at most this fraction of the split graph joins "
      "its most connected sibling instead (0: always refuse)");
  add("min_num_matches",
      &mapper_options.min_num_matches,
      "minimum verified inliers of a view-graph edge (-1: "
      "Mapper.min_num_matches)");
  add("edge_weights",
      &command->edge_weights,
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
  add("mapper_schedule_for_own_cameras",
      &mapper_options.mapper_schedule_for_own_cameras,
      "a community most of whose images have a camera of their own runs the "
      "mapper's own global adjustments (Mapper.ba_global_function_tolerance "
      "and ratios) instead of the two settings above");
  add("merge_other_models",
      &mapper_options.merge_other_models,
      "where a community's mapper made several models, the others that hold "
      "at least Mapper.min_model_size of its images take part in the merge "
      "as extra communities (0: their images are registered one by one by "
      "the refinement)");
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
  add("covisibility_close_ray_angle_deg",
      &mapper_options.covisibility_check.close_ray_angle_deg,
      "image pairs whose rays to their common points are on average at most "
      "this many degrees apart are close views; a rejected similarity under "
      "which close views across the communities were predicted cannot join "
      "parts (join_parts_by_rejected_links)");
  add("confirm_rejected_links",
      &mapper_options.confirm_rejected_links,
      "a similarity the co-visibility check rejected whose inliers the merge "
      "explains through other links (a cycle) was right: its image pairs "
      "stay in the refinement (0: they are left out)");
  add("rejected_link_max_drift_factor",
      &mapper_options.rejected_link_max_drift_factor,
      "the rotation and translation bounds that confirm a rejected "
      "similarity grow as the square root of the number of links that join "
      "its communities (the drift they may have accumulated), at most by "
      "this factor (1: the bounds alone)");
  add("join_parts_by_rejected_links",
      &mapper_options.join_parts_by_rejected_links,
      "two rejected similarities from one community to two communities of "
      "another part, on different points of it and refused by wide views "
      "alone (no close view predicted), join the parts if the averaging "
      "with them keeps them and every link as before (off by default: an "
      "identical building photographed in two communities could be stacked "
      "onto it)");
  add("max_rotation_residual_deg",
      &mapper_options.similarity_averaging.max_rotation_residual_deg,
      "drop a pairwise similarity whose rotation residual after averaging "
      "exceeds this");
  add("min_relative_size",
      &mapper_options.similarity_averaging.min_relative_size,
      "the weaker community of a rejected similarity leaves the merge if its "
      "model is in doubt or it registered fewer images than this fraction "
      "of the median community");
  add("max_log_scale_residual",
      &mapper_options.similarity_averaging.max_log_scale_residual,
      "drop a pairwise similarity whose log scale residual after averaging "
      "exceeds this");
  add("max_relative_translation_residual",
      &mapper_options.similarity_averaging.max_relative_translation_residual,
      "drop a pairwise similarity whose translation residual after averaging, "
      "relative to its points' spread, exceeds this");
  add("max_shared_image_rotation_deg",
      &mapper_options.pairwise_similarity.max_shared_image_rotation_deg,
      "an image both communities registered is placed alike by their models "
      "under a similarity if within this rotation (degrees) ...");
  add("max_shared_image_relative_distance",
      &mapper_options.pairwise_similarity.max_shared_image_relative_distance,
      "... and this distance, relative to the spread of the co-visible "
      "points");
  add("reject_worst_first",
      &mapper_options.similarity_averaging.reject_worst_first,
      "each round of the averaging rejects only the similarity of each part "
      "that is furthest beyond the bounds, and a doubtful or small community "
      "whose one remaining similarity its shared images confirm stays (0: "
      "every similarity beyond the bounds goes at once)");
  add("min_num_contradicting_shared_images",
      &mapper_options.similarity_averaging.min_num_contradicting_shared_images,
      "a similarity under which at least this many shared images are placed "
      "elsewhere is in doubt (a tenth of its weight in the averaging), and "
      "with no fewer alike left out of the averaging from the start (0: "
      "never)");
  add("min_num_shared_images_on_bridge",
      &mapper_options.similarity_averaging.min_num_shared_images_on_bridge,
      "a similarity on no cycle of kept similarities is dropped unless at "
      "least this many shared images are placed alike and at most one is "
      "not (between communities not in doubt, full_support_num_inliers "
      "inliers stand in for the former, and fewer off than alike are "
      "allowed)");
  add("full_support_num_inliers",
      &mapper_options.similarity_averaging.full_support_num_inliers,
      "a similarity with fewer inliers weighs proportionally less in the "
      "averaging, and needs shared images to confirm it on a bridge");
  add("spread_cycle_drift",
      &mapper_options.similarity_averaging.spread_cycle_drift,
      "where a cycle of similarities does not close under L1 averaging but "
      "every similarity beyond the bounds is confirmed by its shared images, "
      "spread the disagreement over the cycle in least squares (drift) if "
      "that brings every similarity within the bounds");
  add("min_num_confirming_shared_images",
      &mapper_options.similarity_averaging.min_num_confirming_shared_images,
      "a similarity beyond the bounds counts as drift only if at least this "
      "many images both communities registered confirm it (all placed "
      "alike, within the residual bounds)");
  add("min_registered_fraction",
      &mapper_options.judgement.min_registered_fraction,
      "a community whose model registered fewer of its images than this "
      "fraction (of the communities' median fraction) is in doubt");
  add("max_relative_reprojection_error",
      &mapper_options.judgement.max_relative_reprojection_error,
      "a community whose model's mean reprojection error exceeds this many "
      "times the communities' median is in doubt");
  add("pose_graph_alignment",
      &mapper_options.align_pose_graph,
      "before the refinement, spread each community's disagreement with its "
      "neighbours over its cameras by a scale-drift-aware pose graph (off by "
      "default: on the benchmark's scenes it bent more than it straightened)");
  add("pose_graph_min_num_shared_points",
      &mapper_options.pose_graph.min_num_shared_points,
      "a pose graph edge links two images of a community that share at least "
      "this many points");
  add("pose_graph_max_num_neighbors",
      &mapper_options.pose_graph.max_num_neighbors,
      "pose graph edges per image (the images it shares the most points "
      "with)");
  add("register_remaining_images",
      &mapper_options.refinement.register_remaining_images,
      "try to register, in the merged model, images no community registered");
  add("register_offered_blocks",
      &mapper_options.refinement.register_offered_blocks,
      "register the model of a community that no kept similarity joins as "
      "one block, through the images the merged model registers in common "
      "with it, instead of image by image");
  add("block_min_num_shared_images",
      &mapper_options.refinement.block_registration.min_num_shared_images,
      "images the merged model and an offered community model must share "
      "before the model is registered as a block");
  add("block_min_inlier_fraction",
      &mapper_options.refinement.block_registration.min_inlier_fraction,
      "fraction of the points of the shared images that the block's "
      "similarity must explain");
  add("robust_first_adjustment",
      &mapper_options.refinement.robust_first_adjustment,
      "align the merged model's cameras under a robust loss");
  add("alignment_max_points_per_image",
      &mapper_options.refinement.alignment_max_points_per_image,
      "points per image (longest tracks first) in the merged model's first "
      "bundle adjustment, which aligns the communities' cameras before all "
      "points are triangulated anew");
  add("triangulation_filter_factor",
      &mapper_options.refinement.triangulation_filter_factor,
      "the merged model's points triangulated anew are filtered at this "
      "multiple of --Mapper.filter_max_reproj_error before its first "
      "bundle adjustment; 0: not before it");
  add("final_filter_noise_multiple",
      &mapper_options.refinement.final_filter_noise_multiple,
      "before and after the merged model's last bundle adjustment, filter "
      "observations beyond this multiple of its reprojection noise (where "
      "below --Mapper.filter_max_reproj_error); 0: off");
  add("max_refinement_change",
      &mapper_options.refinement.max_refinement_change,
      "the merged model's rounds of bundle adjustment, filtering and track "
      "completion stop once fewer than this fraction of the observations "
      "change; -1: --Mapper.ba_global_max_refinement_change");
  add("reload_correspondences",
      &mapper_options.refinement.reload_correspondences,
      "the merged model's bundle adjustments run with the correspondences "
      "released, which are loaded again after each (less memory, one more "
      "database read per round)");
  add("ba_function_tolerance",
      &mapper_options.refinement.function_tolerance,
      "the merged model's bundle adjustments stop once an iteration lowers "
      "the cost by less than this fraction");
  add("ba_initial_trust_region_radius",
      &mapper_options.refinement.initial_trust_region_radius,
      "initial Levenberg-Marquardt trust region radius of the merged model's "
      "bundle adjustments");
  add("reduced_adjustment",
      &mapper_options.refinement.reduced_adjustment,
      "adjust the merged model's cameras on a selected subset of its tracks "
      "(spread over every image), then the other points with the cameras "
      "fixed; 0: every adjustment over all observations");
  add("ba_max_selected_fraction",
      &mapper_options.refinement.max_selected_observation_fraction,
      "reduced adjustment: used only where the selected tracks hold at most "
      "this fraction of the observations (otherwise over all of them)");
  add("ba_track_grid_size",
      &mapper_options.refinement.track_selection.grid_size,
      "reduced adjustment: cells per side of the image grid over which the "
      "tracks are selected (the best track of every cell)");
  add("ba_min_tracks_per_image",
      &mapper_options.refinement.track_selection.min_tracks_per_image,
      "reduced adjustment: selected tracks every image observes at least");
  add("sparse_solver",
      &mapper_options.refinement.sparse_solver,
      "use the sparse direct solver in the merged model's bundle adjustments "
      "at any size (COLMAP switches to the iterative one above 1000 images)");
  add("dense_solver_min_density",
      &mapper_options.refinement.dense_solver_min_density,
      "use the dense Schur solver in the merged model's bundle adjustments "
      "of at most 1000 images where at least this fraction of the pairs of "
      "images see a common point (above 1: never)");
  // Not saved to project.ini: a saved project must not replace results.
  options.AddDefaultOption("CommunityMapper.overwrite",
                           &command->overwrite,
                           stage == CommunityMapperStage::kCommunity
                               ? "reconstruct the community again even if "
                                 "it has a record"
                               : "replace the results of an earlier run in "
                                 "output_path");
  options.AddMapperOptions();
  options.Parse(static_cast<int>(arguments.size()), arguments.data());

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
    // output_path (and image_list_path) first: options outside any section
    // precede the sections.
    command->project_ini =
        "output_path=" + output_path + "\n" +
        (command->image_list_path.empty()
             ? ""
             : "image_list_path=" + command->image_list_path + "\n") +
        text.str() + ini_section.str();
  }
  mapper_options.plan_options = PlanOptions(command->project_ini);
  if (stage == CommunityMapperStage::kCommunity) {
    // Its project would carry --community_id: the partition's stays.
    command->project_ini.clear();
  }
}

int RunStage(int argc, char** argv, const CommunityMapperStage stage) {
  // The phases free their large buffers before the next phase allocates
  // its own (see process_memory.h).
  MapLargeAllocationsApart();
  CommunityMapperCommand command;
  ParseCommand(argc, argv, stage, &command);
  return RunCommunityMapperImpl(command) ? EXIT_SUCCESS : EXIT_FAILURE;
}

}  // namespace

int RunCommunityMapper(int argc, char** argv) {
  return RunStage(argc, argv, CommunityMapperStage::kAll);
}

int RunCommunityPartitioner(int argc, char** argv) {
  return RunStage(argc, argv, CommunityMapperStage::kPartition);
}

int RunCommunityReconstructor(int argc, char** argv) {
  return RunStage(argc, argv, CommunityMapperStage::kCommunity);
}

int RunCommunityMerger(int argc, char** argv) {
  return RunStage(argc, argv, CommunityMapperStage::kMerge);
}

}  // namespace colmap
