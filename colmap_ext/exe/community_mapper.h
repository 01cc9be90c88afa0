// The community mapper's commands (docs/design.md, Outputs and workflow).
//
//   colmap community_mapper --database_path DB --image_path IMAGES
//       --output_path OUT [--CommunityMapper.* ...] [--Mapper.* ...]
//
// runs every stage in one process and resumes a killed run on the same OUT;
// the stages also run alone (scripts/slurm_community_mapper.sh):
//
//   colmap community_partitioner   (same options)   -> OUT/plan.txt, ...
//   colmap community_reconstructor --project_path OUT/project.ini
//       --community_id K                            -> OUT/communities/K
//   colmap community_merger --project_path OUT/project.ini -> OUT/0, ...
//
// Bad input is refused before anything is written; results a command would
// not resume are replaced only with --CommunityMapper.overwrite 1; one run at
// a time writes an OUT (output_lock.h).

#pragma once

#include "colmap_ext/exe/community_mapper_options.h"

#include <string>

namespace colmap {

enum class CommunityMapperStage {
  kAll,        // community_mapper
  kPartition,  // community_partitioner
  kCommunity,  // community_reconstructor --community_id K
  kMerge,      // community_merger
};

struct CommunityMapperCommand {
  CommunityMapperStage stage = CommunityMapperStage::kAll;
  // The options (community_mapper_options.h); checked when the command runs.
  CommunityMapperCommandOptions options;
  // --image_list_path: the image names to reconstruct, one per line (empty:
  // every image); --Mapper.image_list_path itself is refused.
  std::string image_list_path;
  // The community of kCommunity.
  int community_id = -1;
  // Written to OUT/project.ini by the partition and the merge (if not empty).
  std::string project_ini;
  // COLMAP's options alone, written as project.ini beside every merged
  // model as `colmap mapper` does.
  std::string colmap_ini;
};

// Runs the command on parsed options. Returns false, with the reason
// logged, on bad input or failure.
bool RunCommunityMapperImpl(const CommunityMapperCommand& command);

// The commands as registered in colmap.cc.
int RunCommunityMapper(int argc, char** argv);
int RunCommunityPartitioner(int argc, char** argv);
int RunCommunityReconstructor(int argc, char** argv);
int RunCommunityMerger(int argc, char** argv);

}  // namespace colmap
