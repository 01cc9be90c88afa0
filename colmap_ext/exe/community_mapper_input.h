// What `colmap community_mapper` checks of its input before it writes
// anything: the database, the image list and the image folder. Each check
// logs what is wrong and what to do.
#pragma once

#include "colmap_ext/workflow/community_mapper.h"

#include <string>
#include <vector>

namespace colmap {

// Says what the database lacks (no file, not a COLMAP database, no images,
// features or verified pairs with at least `min_num_matches` inliers); a
// usable database written by COLMAP 3 is then migrated to COLMAP 4's layout,
// its original kept beside it (database_migration.h). False, with the
// reason logged, if it cannot be used; it is then unchanged.
bool CheckDatabase(const std::string& path, int min_num_matches);

// Reads --image_list_path into options->image_names, each name an image of
// the database, and records the list in the plan's options (a plan made
// with another list does not fit). False, with the reason logged, if the
// file is missing or empty or names an image the database lacks.
bool ReadImageListIntoOptions(const std::string& path,
                              CommunityMapperController::Options* options);

// Warns if the image folder is missing or empty: the images are only read
// for the points' colours.
void CheckImagePath(const std::string& image_path);

// Takes --community_id N (or --community_id=N) out of the arguments into
// `community_id`: it is read from the command line even with --project_path
// (whose options replace the command line's in COLMAP's OptionManager), so
// that the jobs of an array share one project file. False (logged) if N is
// not a number.
bool TakeCommunityId(std::vector<char*>* arguments, int* community_id);

// With --project_path, COLMAP's OptionManager reads every option from the
// file and silently drops the command line's: false (logged, naming them)
// where options are given beside it, so that nobody merges again believing
// an option changed.
bool CheckNothingBesideProjectPath(const std::vector<char*>& arguments);

}  // namespace colmap
