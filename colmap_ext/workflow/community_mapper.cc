#include "colmap_ext/workflow/community_mapper.h"

#include "colmap_ext/workflow/community_io.h"
#include "colmap_ext/reconstruction/community_reconstruction.h"
#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/workflow/database_retry.h"
#include "colmap_ext/util/log_tag.h"
#include "colmap_ext/util/option_check.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/scene/database.h"
#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/misc.h"
#include "colmap/util/string.h"
#include "colmap/util/threading.h"
#include "colmap/util/timer.h"

#include <algorithm>

namespace colmap {

CommunityMergerOptions CommunityMapperController::Options::MergeOptions()
    const {
  CommunityMergerOptions merge_options = merge;
  merge_options.database_path = database_path;
  merge_options.image_path = image_path;
  merge_options.image_names = image_names;
  merge_options.min_num_matches = incremental_options.min_num_matches;
  merge_options.incremental_options = incremental_options;
  merge_options.refinement_function_tolerance =
      ba_function_tolerance >= 0
          ? ba_function_tolerance
          : incremental_options.ba_global_function_tolerance;
  return merge_options;
}

IncrementalPipelineOptions
CommunityMapperController::Options::CommunityIncrementalOptions(
    const std::unordered_set<std::string>& image_names,
    const int num_threads,
    const bool only_community) const {
  IncrementalPipelineOptions community_options = incremental_options;
  community_options.image_names.assign(image_names.begin(), image_names.end());
  std::sort(community_options.image_names.begin(),
            community_options.image_names.end());
  community_options.image_path = image_path;
  if (community_options.num_threads < 0) {
    community_options.num_threads = num_threads;
  }
  if (!only_community && ba_function_tolerance >= 0) {
    community_options.ba_global_function_tolerance = ba_function_tolerance;
  }
  return community_options;
}

bool CommunityMapperController::Options::Check() const {
  bool valid = community_detection.Check();
  valid &= CheckFlag(
      image_overlap >= 0, "image_overlap", image_overlap, "0 or more");
  valid &= CheckFlag(num_workers > 0 || num_workers == -1,
                     "num_workers",
                     num_workers,
                     "positive, or -1 for one per CPU core");
  valid &=
      CheckFlag(ba_function_tolerance >= 0 || ba_function_tolerance == -1,
                "ba_function_tolerance",
                ba_function_tolerance,
                "0 or more, or -1 for --Mapper.ba_global_function_tolerance");
  return valid && MergeOptions().Check();  // With incremental_options'.
}

CommunityMapperController::CommunityMapperController(
    const Options& options,
    std::shared_ptr<ReconstructionManager> reconstruction_manager)
    : options_(options),
      workspace_(options.output_path),
      reconstruction_manager_(std::move(reconstruction_manager)) {
  THROW_CHECK(options_.Check());
  THROW_CHECK(!options_.output_path.empty());
}

bool CommunityMapperController::Partition() {
  if (ExistsFile(workspace_.PlanPath())) {
    if (!LoadPlan()) {
      return false;
    }
    LOG(INFO) << "Resuming the run in " << options_.output_path << ": "
              << workspace_.PlanPath()
              << " exists and fits the database and options.";
    return true;
  }
  Timer timer;
  timer.Start();
  const std::shared_ptr<Database> database =
      Database::Open(options_.database_path);
  database_fingerprint_ = DatabaseFingerprint(*database);
  const ViewGraph view_graph =
      ViewGraph::Read(*database,
                      options_.incremental_options.min_num_matches,
                      options_.image_names);
  // The partition's vertices are frames (rig snapshots, one pose each): a
  // frame's images stay in one community, and communities borrow frames.
  const WeightedGraph graph = view_graph.ToFrameGraph(options_.edge_weight);
  const std::vector<std::vector<int>>& frames = view_graph.FrameVertices();
  const std::vector<std::vector<int>> components =
      view_graph.ToWeightedGraph(options_.edge_weight).ConnectedComponents();
  summary_.num_view_graph_images = static_cast<int>(view_graph.NumVertices());
  summary_.num_view_graph_edges = static_cast<int>(view_graph.NumEdges());
  LOG(INFO) << StringPrintf(
      "View graph: %d images, %d edges (>= %d inlier matches), %d connected "
      "component(s), the largest with %d images",
      summary_.num_view_graph_images,
      summary_.num_view_graph_edges,
      options_.incremental_options.min_num_matches,
      static_cast<int>(components.size()),
      components.empty() ? 0 : static_cast<int>(components[0].size()));
  if (view_graph.NumEdges() == 0) {
    LOG(ERROR) << "The database has no verified image pairs with at least "
               << options_.incremental_options.min_num_matches << " inlier matches"
               << (options_.image_names.empty()
                       ? ""
                       : " between two of the listed images")
               << ": run a matcher first.";
    return false;
  }

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), options_.community_detection);

  plan_ = CommunityPlan();
  plan_.database_path = options_.database_path;
  plan_.database_fingerprint = database_fingerprint_;
  plan_.options = options_.plan_options;
  plan_.max_modularity = partition.MaxModularity();
  plan_.num_view_graph_components = static_cast<int>(components.size());
  plan_.communities.resize(partition.NumCommunities());
  CommunityPartition image_partition = partition;  // By image.
  image_partition.membership.resize(view_graph.NumVertices());
  for (size_t frame = 0; frame < frames.size(); ++frame) {
    for (const int vertex : frames[frame]) {
      image_partition.membership[vertex] = partition.membership[frame];
      plan_.communities[partition.membership[frame]]
          .own_image_names.push_back(view_graph.ImageNames()[vertex]);
    }
  }
  const std::vector<std::vector<int>> extended =
      ExtendCommunities(graph, partition, options_.image_overlap);
  for (size_t c = 0; c < extended.size(); ++c) {
    for (const int frame : extended[c]) {
      for (const int vertex : frames[frame]) {
        if (partition.membership[frame] != static_cast<int>(c)) {
          plan_.communities[c].borrowed_image_names.push_back(
              view_graph.ImageNames()[vertex]);
        }
      }
    }
  }
  has_plan_ = true;
  SummarizePlan();
  LOG(INFO) << StringPrintf(
      "%d communities (%d before merging those under %d images), sizes:%s",
      partition.NumCommunities(),
      partition.num_communities_before_merge,
      options_.community_detection.min_community_size,
      SpaceSeparated(summary_.community_sizes).c_str());

  // The plan is written last: it marks a finished partition.
  CreateDirIfNotExists(options_.output_path, /*recursive=*/true);
  WriteTextFileAtomically(
      CommunitiesToText(view_graph,
                        image_partition,
                        options_.community_detection.modularity_threshold,
                        options_.edge_weight),
      workspace_.CommunitiesPath());
  WriteTextFileAtomically(CommunityPlanToText(plan_), workspace_.PlanPath());
  LOG(INFO) << "Wrote " << workspace_.CommunitiesPath() << " and "
            << workspace_.PlanPath()
            << StringPrintf(" (%.3fs)", timer.ElapsedSeconds());
  return true;
}

bool CommunityMapperController::LoadPlan() {
  if (has_plan_) {
    return true;
  }
  if (!ExistsFile(workspace_.PlanPath())) {
    LOG(ERROR) << workspace_.PlanPath()
               << " does not exist: partition first (colmap "
                  "community_partitioner, or community_mapper).";
    return false;
  }
  try {
    plan_ = CommunityPlanFromText(ReadTextFile(workspace_.PlanPath()));
  } catch (const std::exception& error) {
    LOG(ERROR) << workspace_.PlanPath() << " cannot be read: " << error.what()
               << ". Partition again with --CommunityMapper.overwrite 1.";
    return false;
  }
  if (database_fingerprint_.empty()) {
    // Tried again while another task of a job array holds the database.
    RetryDatabaseAccessOrThrow(options_.database_path, [this]() {
      database_fingerprint_ =
          DatabaseFingerprint(*Database::Open(options_.database_path));
    });
  }
  const std::string mismatch =
      PlanMismatch(plan_, database_fingerprint_, options_.plan_options);
  if (!mismatch.empty()) {
    LOG(ERROR) << "The plan in " << options_.output_path
               << " does not fit this run: " << mismatch
               << ". Use the database and options of the plan, or start over "
                  "with --CommunityMapper.overwrite 1 (or another "
                  "--output_path).";
    return false;
  }
  has_plan_ = true;
  SummarizePlan();
  return true;
}

void CommunityMapperController::SummarizePlan() {
  summary_.max_modularity = plan_.max_modularity;
  summary_.community_sizes.clear();
  for (const auto& community : plan_.communities) {
    summary_.community_sizes.push_back(
        static_cast<int>(community.own_image_names.size()));
  }
}

bool CommunityMapperController::IsReconstructed(const int community_id) const {
  const std::string path = workspace_.CommunityRecordPath(community_id);
  if (!ExistsFile(path)) {
    return false;
  }
  try {
    const CommunityRecord record = CommunityRecordFromText(ReadTextFile(path));
    bool has_models = record.num_registered == 0 ||
                      IsModelDir(workspace_.CommunityModelPath(community_id));
    for (int index = 1; index <= record.num_other_models; ++index) {
      has_models = has_models && IsModelDir(workspace_.CommunityOtherModelPath(
                                     community_id, index));
    }
    return record.community_id == community_id &&
           record.database_fingerprint == plan_.database_fingerprint &&
           has_models;
  } catch (const std::exception&) {
    return false;
  }
}

bool CommunityMapperController::ReconstructAndRecord(
    const int community_id, const int num_threads, std::mutex* database_mutex) {
  ScopedLogTag log_tag(StringPrintf("community %d", community_id));
  const CommunityPlan::Community& community = plan_.communities[community_id];
  std::unordered_set<std::string> image_names(community.own_image_names.begin(),
                                              community.own_image_names.end());
  image_names.insert(community.borrowed_image_names.begin(),
                     community.borrowed_image_names.end());
  LOG(INFO) << StringPrintf(
      "Reconstructing community %d (%d images, %d shared with neighbours)",
      community_id,
      static_cast<int>(community.own_image_names.size()),
      static_cast<int>(community.borrowed_image_names.size()));
  Timer timer;
  timer.Start();
  CommunityRecord record;
  record.community_id = community_id;
  record.num_images = static_cast<int>(image_names.size());
  record.database_fingerprint = plan_.database_fingerprint;
  try {
    const CommunityReconstruction reconstruction =
        colmap::ReconstructCommunityModels(
            std::make_shared<IncrementalPipelineOptions>(
                options_.CommunityIncrementalOptions(
                    image_names,
                    num_threads,
                    /*only_community=*/plan_.NumCommunities() == 1)),
            options_.image_path,
            options_.database_path,
            database_mutex);
    record.num_models = reconstruction.num_models;
    if (reconstruction.model && reconstruction.model->NumRegImages() > 0) {
      const Reconstruction& model = *reconstruction.model;
      record.num_registered = static_cast<int>(model.NumRegImages());
      record.num_points = static_cast<int>(model.NumPoints3D());
      record.mean_reprojection_error = model.ComputeMeanReprojectionError();
      CreateDirIfNotExists(workspace_.CommunitiesDir());
      WriteReconstructionAtomically(
          model, workspace_.CommunityModelPath(community_id));
      // The other models (largest first) that the merge may use, as the
      // incremental mapper would keep them: of at least min_model_size.
      for (const auto& other_model : reconstruction.other_models) {
        if (static_cast<int>(other_model->NumRegImages()) <
            options_.incremental_options.min_model_size) {
          break;
        }
        ++record.num_other_models;
        WriteReconstructionAtomically(
            *other_model,
            workspace_.CommunityOtherModelPath(community_id,
                                               record.num_other_models));
      }
    }
  } catch (const std::exception& error) {
    LOG(ERROR) << StringPrintf(
        "Community %d failed: %s", community_id, error.what());
    return false;
  }
  record.seconds = timer.ElapsedSeconds();
  // The record is written last: it marks a finished community.
  CreateDirIfNotExists(workspace_.CommunitiesDir());
  WriteTextFileAtomically(CommunityRecordToText(record),
                          workspace_.CommunityRecordPath(community_id));
  if (record.num_registered == 0) {
    LOG(WARNING) << DescribeCommunityRecord(record);
  } else {
    LOG(INFO) << DescribeCommunityRecord(record);
  }
  return true;
}

bool CommunityMapperController::ReconstructCommunity(const int community_id) {
  if (!LoadPlan()) {
    return false;
  }
  if (community_id < 0 || community_id >= plan_.NumCommunities()) {
    LOG(ERROR) << "Community " << community_id << " is not in the plan of "
               << options_.output_path << ", which has communities 0 to "
               << plan_.NumCommunities() - 1 << ".";
    return false;
  }
  if (IsReconstructed(community_id)) {
    LOG(INFO) << "Community " << community_id << " has a record in "
              << workspace_.CommunityRecordPath(community_id)
              << ": it is reused (--CommunityMapper.overwrite 1 reconstructs "
                 "it again).";
    return true;
  }
  std::mutex database_mutex;
  return ReconstructAndRecord(
      community_id, GetEffectiveNumThreads(-1), &database_mutex);
}

bool CommunityMapperController::CheckAllReconstructed() const {
  std::vector<int> missing;
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    if (!IsReconstructed(c)) {
      missing.push_back(c);
    }
  }
  LOG_IF(ERROR, !missing.empty()) << StringPrintf(
      "%d of the %d communities of the plan have not been reconstructed "
      "(no record in %s): %s. Reconstruct them first (colmap "
      "community_reconstructor --community_id K).",
      static_cast<int>(missing.size()),
      plan_.NumCommunities(),
      workspace_.CommunitiesDir().c_str(),
      VectorToCSV(missing).c_str());
  return missing.empty();
}

void CommunityMapperController::EndPhase(const std::string& name,
                                         const double seconds) {
  summary_.phase_seconds.emplace_back(name, seconds);
  LOG(INFO) << StringPrintf("%s: %.3fs (%s)",
                            name.c_str(),
                            seconds,
                            ProcessMemoryToString(ReadProcessMemory()).c_str());
}

bool CommunityMapperController::Merge() {
  if (!LoadPlan() || !CheckAllReconstructed()) {
    return false;
  }
  CommunityMerger merger(options_.MergeOptions(), plan_, workspace_);
  merger.Solve();  // Logs each stage's seconds.
  static_cast<CommunityMergerResult&>(summary_) = merger.Result();
  summary_.phase_seconds.insert(summary_.phase_seconds.end(),
                                summary_.stage_seconds.begin(),
                                summary_.stage_seconds.end());
  summary_.peak_memory_mb = ReadProcessMemory().peak_resident_mb;
  if (summary_.models.empty()) {
    LOG(ERROR) << "No community could be reconstructed: no model written.";
    return false;
  }
  for (const auto& model : summary_.models) {
    summary_.model_num_registered.push_back(
        static_cast<int>(model->NumRegImages()));
    reconstruction_manager_->Get(reconstruction_manager_->Add()) = model;
  }
  try {
    WriteTextFileAtomically(
        CommunityCamerasToPly(*summary_.models[0], summary_.community_of_image),
        workspace_.CommunitiesPlyPath());
  } catch (const std::exception& error) {
    LOG(WARNING) << "Could not write " << workspace_.CommunitiesPlyPath()
                 << ": " << error.what();
  }
  return true;
}

bool CommunityMapperController::RunAllStages() {
  Timer run_timer;
  run_timer.Start();
  summary_ = CommunityMapperSummary();
  Timer phase_timer;

  LOG_HEADING1("1. Partitioning the view graph into communities");
  phase_timer.Start();
  if (!Partition()) {
    return false;
  }
  EndPhase("Partition", phase_timer.ElapsedSeconds());

  LOG_HEADING1("2. Reconstructing the communities");
  phase_timer.Restart();
  std::vector<int> to_reconstruct;
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    (IsReconstructed(c) ? summary_.reused_communities : to_reconstruct)
        .push_back(c);
  }
  LOG_IF(INFO, !summary_.reused_communities.empty())
      << "Reusing the communities reconstructed by an earlier run of this plan:"
      << SpaceSeparated(summary_.reused_communities);
  const int num_threads = GetEffectiveNumThreads(-1);
  const int num_workers =
      options_.num_workers > 0
          ? options_.num_workers
          : std::clamp(static_cast<int>(to_reconstruct.size()), 1, num_threads);
  const int num_threads_per_worker = std::max(1, num_threads / num_workers);
  LOG(INFO) << StringPrintf(
      "Reconstructing %d communities with %d workers, %d threads each",
      static_cast<int>(to_reconstruct.size()),
      num_workers,
      num_threads_per_worker);
  std::mutex database_mutex;
  std::mutex progress_mutex;
  // Communities are numbered largest first, the order that keeps the
  // workers busiest.
  ThreadPool thread_pool(num_workers);
  for (const int c : to_reconstruct) {
    thread_pool.AddTask([&, c]() {
      if (!ReconstructAndRecord(c, num_threads_per_worker, &database_mutex)) {
        return;
      }
      std::lock_guard<std::mutex> lock(progress_mutex);
      summary_.reconstructed_communities.push_back(c);
      LOG(INFO) << StringPrintf(
          "Communities done: %d of %d (%.0fs, %s)",
          static_cast<int>(summary_.reconstructed_communities.size() +
                           summary_.reused_communities.size()),
          plan_.NumCommunities(),
          phase_timer.ElapsedSeconds(),
          ProcessMemoryToString(ReadProcessMemory()).c_str());
    });
  }
  thread_pool.Wait();
  ReleaseFreedMemory();  // The workers' heaps (see process_memory.h).
  EndPhase("Communities", phase_timer.ElapsedSeconds());
  if (CheckIfStopped()) {
    return false;
  }

  LOG_HEADING1("3. Merging the communities");
  const bool merged = Merge();
  LogCommunityMapperSummary(summary_);
  run_timer.PrintMinutes();
  return merged;
}

}  // namespace colmap
