// The community mapper's commands.
//
//   colmap community_mapper --database_path DB --image_path IMAGES
//       --output_path OUT [--CommunityMapper.* ...] [--Mapper.* ...]
//
// runs every stage in one process (partition, the communities, the merge)
// and resumes a killed run of the same command on the same OUT. The stages
// also run alone, e.g. as the jobs of a cluster's scheduler
// (scripts/slurm_community_mapper.sh):
//
//   colmap community_partitioner   (same options)   -> OUT/plan.txt, ...
//   colmap community_reconstructor --project_path OUT/project.ini
//       --community_id K                            -> OUT/communities/K
//   colmap community_merger --project_path OUT/project.ini -> OUT/0, ...
//
// OUT's layout is community_workspace.h's. Bad input is refused with a
// message naming the problem before anything is written; results of an
// earlier run that the command would not resume are only replaced with
// --CommunityMapper.overwrite 1; one run at a time writes an OUT
// (output_lock.h).

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
  // The options (community_mapper_options.h); their values are checked by
  // RunCommunityMapperImpl.
  CommunityMapperCommandOptions options;
  // --image_list_path: a text file of the image names to reconstruct, one
  // per line, as colmap mapper's --Mapper.image_list_path (empty: every
  // image of the database). --Mapper.image_list_path itself is refused.
  std::string image_list_path;
  // The community of kCommunity.
  int community_id = -1;
  // Written to OUT/project.ini by the partition and the merge (if not empty).
  std::string project_ini;
  // COLMAP's options alone, written as project.ini beside every merged
  // model as `colmap mapper` does (the GUI reads the database and image
  // paths from it).
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
