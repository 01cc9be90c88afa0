#include "colmap_ext/exe/community_mapper_input.h"

#include "colmap_ext/workflow/community_io.h"
#include "colmap_ext/workflow/community_workspace.h"
#include "colmap_ext/workflow/database_migration.h"
#include "colmap_ext/workflow/sqlite_connection.h"

#include "colmap/scene/database.h"
#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <filesystem>
#include <system_error>

namespace colmap {

bool ReadImageListIntoOptions(const std::string& path,
                              CommunityMapperController::Options* options) {
  std::vector<std::string> names;
  const std::string problem = ReadImageList(path, &names);
  if (!problem.empty()) {
    LOG(ERROR) << problem;
    return false;
  }
  const std::shared_ptr<Database> database =
      Database::Open(options->database_path);
  std::vector<std::string> unknown;
  for (const std::string& name : names) {
    if (!database->ExistsImageWithName(name)) {
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

namespace {

// Whether the database at `path` holds what a reconstruction needs; logs
// what is missing and what to do otherwise.
bool CheckDatabaseContents(const std::string& path, const int min_num_matches) {
  if (!ExistsFile(path)) {
    LOG(ERROR) << "The database " << path
               << " does not exist. Check --database_path, or create it with "
                  "`colmap feature_extractor` and a matcher (e.g. `colmap "
                  "exhaustive_matcher`).";
    return false;
  }
  std::string open_error;
  const SqliteConnection database(path, SQLITE_OPEN_READONLY, &open_error);
  if (database.get() == nullptr) {
    LOG(ERROR) << "Cannot open the database " << path << ": " << open_error
               << ".";
    return false;
  }

  int64_t num_tables = 0;
  if (!database.QueryInteger(
          "SELECT COUNT(*) FROM sqlite_master WHERE type='table' AND "
          "name IN ('images', 'keypoints', 'two_view_geometries')",
          &num_tables)) {
    LOG(ERROR) << "Cannot read the database " << path << ": "
               << sqlite3_errmsg(database.get())
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
  if (!database.QueryInteger("SELECT COUNT(*) FROM images", &num_images) ||
      !database.QueryInteger("SELECT COUNT(*) FROM keypoints WHERE rows > 0",
                             &num_keypoints) ||
      !database.QueryInteger(
          "SELECT COUNT(*) FROM two_view_geometries WHERE rows >= " +
              std::to_string(min_num_matches),
          &num_pairs)) {
    LOG(ERROR) << "Cannot read the database " << path << ": "
               << sqlite3_errmsg(database.get()) << ".";
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

}  // namespace

bool CheckDatabase(const std::string& path, const int min_num_matches) {
  if (!CheckDatabaseContents(path, min_num_matches)) {
    return false;
  }
  try {
    if (IsColmap3Database(path)) {
      MigrateColmap3Database(path);
    }
  } catch (const std::exception& error) {
    LOG(ERROR) << "The database " << path << " was written by COLMAP 3 and "
               << "could not be migrated to COLMAP 4's layout (" << error.what()
               << "). It is unchanged.";
    return false;
  }
  return true;
}

void CheckImagePath(const std::string& image_path) {
  if (!ExistsDir(image_path)) {
    LOG(WARNING) << "--image_path " << image_path
                 << " is not a folder: the points will have no colours.";
    return;
  }
  std::error_code error;
  LOG_IF(WARNING, std::filesystem::is_empty(image_path, error) && !error)
      << "--image_path " << image_path
      << " is empty: the points will have no colours.";
}

bool TakeCommunityId(std::vector<char*>* arguments, int* community_id) {
  for (size_t i = 1; i < arguments->size(); ++i) {
    const std::string argument = (*arguments)[i];
    std::string value;
    if (argument == "--community_id" && i + 1 < arguments->size()) {
      value = (*arguments)[i + 1];
      arguments->erase(arguments->begin() + i, arguments->begin() + i + 2);
    } else if (argument.rfind("--community_id=", 0) == 0) {
      value = argument.substr(15);
      arguments->erase(arguments->begin() + i);
    } else {
      continue;
    }
    try {
      size_t end = 0;
      *community_id = std::stoi(value, &end);
      if (end != value.size()) throw std::invalid_argument(value);
    } catch (const std::logic_error&) {
      LOG(ERROR) << "--community_id " << value << " is not a number.";
      return false;
    }
    return true;
  }
  return true;
}

bool CheckNothingBesideProjectPath(const std::vector<char*>& arguments) {
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
    return false;
  }
  return true;
}

}  // namespace colmap
