#include "colmap_ext/exe/community_mapper.h"

#include "colmap_ext/exe/community_mapper_input.h"
#include "colmap_ext/workflow/community_workspace.h"
#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/workflow/database_retry.h"
#include "colmap_ext/util/log_tag.h"
#include "colmap_ext/workflow/output_lock.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/controllers/option_manager.h"
#include "colmap/util/file.h"
#include "colmap/util/logging.h"

#include <filesystem>

namespace colmap {
namespace {

// The command of each stage, in CommunityMapperStage's order.
const char* StageName(const CommunityMapperStage stage) {
  static const char* const kNames[] = {"community_mapper",
                                       "community_partitioner",
                                       "community_reconstructor",
                                       "community_merger"};
  return kNames[static_cast<int>(stage)];
}

// Decides what the command may do with the results already in OUT: resume
// them (a plan of the same database and options: the controller checks
// that), replace them (--CommunityMapper.overwrite 1), or nothing (refused).
bool PrepareWorkspace(const CommunityMapperCommand& command,
                      const CommunityWorkspace& workspace,
                      OutputLock* lock) {
  const bool has_plan = ExistsFile(workspace.PlanPath());
  const bool later_stage = command.stage == CommunityMapperStage::kCommunity ||
                           command.stage == CommunityMapperStage::kMerge;
  if (later_stage && !has_plan) {
    LOG(ERROR) << workspace.PlanPath()
               << " does not exist: run `colmap community_partitioner` with "
                  "this --output_path first.";
    return false;
  }
  std::string problem = workspace.CreateOutputFolder();
  if (problem.empty() && command.stage != CommunityMapperStage::kCommunity) {
    // The jobs of an array write different communities: they hold no lock.
    problem = lock->Acquire(workspace.OutputPath());
  }
  if (!problem.empty()) {
    LOG(ERROR) << problem;
    return false;
  }
  if (later_stage) {
    return true;
  }
  if (command.options.overwrite) {
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
               << " but no plan to resume. Choose another folder, or pass "
                  "--CommunityMapper.overwrite 1 to replace them.";
    return false;
  }
  return true;
}

// The controller's options of `command`, checked and with the image list
// read; false (with the reasons logged) if they cannot be used.
bool ControllerOptions(const CommunityMapperCommand& command,
                       CommunityMapperController::Options* options) {
  *options = command.options.mapper;
  if (command.options.edge_weights != "unit" &&
      command.options.edge_weights != "num_inliers") {
    LOG(ERROR) << "--CommunityMapper.edge_weights is '"
               << command.options.edge_weights
               << "': use 'unit' or 'num_inliers'.";
    return false;
  }
  options->edge_weight =
      ViewGraphEdgeWeightFromString(command.options.edge_weights);
  if (!options->Check()) {
    LOG(ERROR) << "Invalid option values (see above).";
    return false;
  }
  if (!options->incremental_options.image_names.empty()) {
    LOG(ERROR) << "--Mapper.image_list_path is not read by "
               << StageName(command.stage)
               << ": give the list as --image_list_path.";
    return false;
  }
  if (command.stage == CommunityMapperStage::kCommunity &&
      command.community_id < 0) {
    LOG(ERROR) << "--community_id is missing or negative: give the community "
                  "to reconstruct, 0 to N-1 for the N communities in "
               << CommunityWorkspace(options->output_path).PlanPath() << ".";
    return false;
  }
  return CheckDatabase(options->database_path,
                       options->incremental_options.min_num_matches) &&
         (command.image_list_path.empty() ||
          ReadImageListIntoOptions(command.image_list_path, options));
}

// Runs the stage's controller; false if it failed (logged).
bool RunController(
    const CommunityMapperCommand& command,
    const CommunityMapperController::Options& options,
    std::shared_ptr<ReconstructionManager> reconstruction_manager,
    CommunityMapperSummary* summary) {
  try {
    CommunityMapperController controller(options,
                                         std::move(reconstruction_manager));
    bool success = true;
    switch (command.stage) {
      case CommunityMapperStage::kAll:
        success = controller.RunAllStages();
        break;
      case CommunityMapperStage::kPartition:
        success = controller.Partition();
        break;
      case CommunityMapperStage::kCommunity:
        if (command.options.overwrite) {
          CommunityWorkspace(options.output_path)
              .RemoveCommunity(command.community_id);
        }
        success = controller.ReconstructCommunity(command.community_id);
        break;
      case CommunityMapperStage::kMerge:
        success = controller.Merge();
        break;
    }
    *summary = controller.GetSummary();
    return success;
  } catch (const std::exception& error) {
    LOG(ERROR) << StageName(command.stage) << " failed: " << error.what();
    return false;
  }
}

// Writes what the stage leaves in OUT besides the controller's files, and
// returns the outputs to name in the log.
std::vector<std::string> WriteOutputs(
    const CommunityMapperCommand& command,
    const CommunityWorkspace& workspace,
    const ReconstructionManager& reconstruction_manager,
    const CommunityMapperSummary& summary) {
  if (command.stage == CommunityMapperStage::kCommunity) {
    return {workspace.CommunityModelPath(command.community_id) +
            " (the community's model) and its record " +
            workspace.CommunityRecordPath(command.community_id)};
  }
  if (!command.project_ini.empty()) {
    WriteTextFileAtomically(command.project_ini, workspace.ProjectPath());
  }
  if (command.stage == CommunityMapperStage::kPartition) {
    return {workspace.CommunitiesPath() + " (the partition)",
            workspace.PlanPath() +
                " (what the community and merge stages read)"};
  }
  std::vector<std::shared_ptr<const Reconstruction>> models;
  for (size_t i = 0; i < reconstruction_manager.Size(); ++i) {
    models.push_back(reconstruction_manager.Get(i));
  }
  workspace.WriteMergedModels(models);
  for (size_t i = 0; i < models.size(); ++i) {
    WriteTextFileAtomically(
        command.colmap_ini,
        (std::filesystem::path(workspace.MergedModelPath(i)) / "project.ini")
            .string());
  }
  WriteTextFileAtomically(CommunityMapperSummaryToText(summary),
                          workspace.SummaryPath());
  return {workspace.MergedModelPath(0) +
              (models.size() > 1 ? " .. " + std::to_string(models.size() - 1)
                                 : std::string()) +
              " (the merged model" + (models.size() > 1 ? "s" : "") +
              ", largest first)",
          (std::filesystem::path(workspace.CommunitiesDir()) / "K").string() +
              " (each community's own model)",
          workspace.CommunitiesPlyPath() +
              " (camera centres of model 0, coloured by community)",
          workspace.ProjectPath(),
          workspace.SummaryPath() +
              " (figures of the run: phases, memory, models)"};
}

// Parses the command line of `stage`'s command into `command`. False (with
// the reason logged) on unparsable options; exits on --help, as every COLMAP
// command does.
bool ParseCommand(int argc,
                  char** argv,
                  const CommunityMapperStage stage,
                  CommunityMapperCommand* command) {
  InstallTaggedLogPrefix("colmap");
  command->stage = stage;
  CommunityMapperController::Options& mapper_options =
      command->options.mapper;

  std::vector<char*> arguments(argv, argv + argc);
  if ((stage == CommunityMapperStage::kCommunity &&
       !TakeCommunityId(&arguments, &command->community_id)) ||
      !CheckNothingBesideProjectPath(arguments)) {
    return false;
  }

  OptionManager options;
  options.AddDatabaseOptions();
  options.AddImageOptions();
  options.AddRequiredOption("output_path", &mapper_options.output_path);
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

  AddCommunityMapperOptions(&command->options, &options);
  options.AddMapperOptions();
  if (!options.Parse(static_cast<int>(arguments.size()), arguments.data())) {
    return false;
  }

  mapper_options.database_path = options.database_path->string();
  mapper_options.image_path = options.image_path->string();
  mapper_options.incremental_options = *options.mapper;

  // project.ini: output_path (and image_list_path) first, as options
  // outside any section precede the sections; COLMAP's options; the
  // CommunityMapper section.
  command->colmap_ini = ColmapOptionsToIni(
      options, {"output_path", "image_list_path", "community_id"});
  command->project_ini =
      "output_path=" + mapper_options.output_path + "\n" +
      (command->image_list_path.empty()
           ? ""
           : "image_list_path=" + command->image_list_path + "\n") +
      command->colmap_ini + CommunityMapperIniSection(command->options);
  mapper_options.plan_options = PlanOptionsFromIni(command->project_ini);
  if (stage == CommunityMapperStage::kCommunity) {
    // Its project would carry --community_id: the partition's stays.
    command->project_ini.clear();
  }
  return true;
}

int RunStage(int argc, char** argv, const CommunityMapperStage stage) {
  // The phases free their large buffers before the next phase allocates
  // its own (see process_memory.h).
  MapLargeAllocationsApart();
  // The jobs of a cluster's job array open one database together.
  WaitOnLockedDatabases();
  CommunityMapperCommand command;
  if (!ParseCommand(argc, argv, stage, &command)) {
    return EXIT_FAILURE;
  }
  return RunCommunityMapperImpl(command) ? EXIT_SUCCESS : EXIT_FAILURE;
}

}  // namespace

bool RunCommunityMapperImpl(const CommunityMapperCommand& command) {
  CommunityMapperController::Options options;
  const CommunityWorkspace workspace(command.options.mapper.output_path);
  OutputLock lock;
  if (!ControllerOptions(command, &options) ||
      !PrepareWorkspace(command, workspace, &lock)) {
    return false;
  }
  if (command.stage == CommunityMapperStage::kAll ||
      command.stage == CommunityMapperStage::kMerge) {
    CheckImagePath(options.image_path);
  }
  auto models = std::make_shared<ReconstructionManager>();
  CommunityMapperSummary summary;
  if (!RunController(command, options, models, &summary)) {
    return false;
  }
  std::vector<std::string> outputs;
  try {
    outputs = WriteOutputs(command, workspace, *models, summary);
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
