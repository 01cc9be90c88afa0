// `colmap community_mapper`: community-based SfM as a COLMAP command.
//
//   colmap community_mapper --database_path DB --image_path IMAGES
//       --output_path OUT [--CommunityMapper.* ...] [--Mapper.* ...]
//
// Writes OUT/communities.txt as soon as the partition is known, one model per
// community in OUT/communities/K/ as each finishes, then the merged models
// OUT/0, OUT/1, ... (largest first), OUT/communities.ply and OUT/project.ini.
// Bad input is refused with a message naming the problem before anything
// is written; existing results in OUT are only replaced with
// --CommunityMapper.overwrite 1.

#pragma once

#include "colmap_ext/controllers/community_mapper.h"

#include <string>

namespace colmap {

// Runs the command on parsed options (options.output_path is OUT). Returns
// false, with the reason logged, on bad input or failure. A non-empty
// `project_ini` is written to OUT/project.ini beside the models.
bool RunCommunityMapperImpl(const CommunityMapperController::Options& options,
                            bool overwrite,
                            const std::string& project_ini = "");

// The command as registered in colmap.cc: parses the options and runs
// RunCommunityMapperImpl.
int RunCommunityMapper(int argc, char** argv);

}  // namespace colmap
