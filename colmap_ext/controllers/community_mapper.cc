#include "colmap_ext/controllers/community_mapper.h"

#include "colmap_ext/scene/community_io.h"
#include "colmap_ext/util/atomic_output.h"
#include "colmap_ext/util/log_tag.h"

#include "colmap/math/math.h"
#include "colmap/scene/database.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/misc.h"
#include "colmap/util/threading.h"
#include "colmap/util/timer.h"

#include <algorithm>
#include <map>
#include <mutex>
#include <set>

namespace colmap {
namespace {

using Models = std::vector<std::shared_ptr<Reconstruction>>;

// The images of every community: its own (by id) and those its
// reconstruction uses, its own plus the overlap with its neighbours (by
// name).
struct CommunityImages {
  std::vector<std::unordered_set<image_t>> own_image_ids;
  std::vector<std::unordered_set<std::string>> image_names;
  std::unordered_map<image_t, std::string> name_of_image;
};

CommunityImages GroupImagesByCommunity(const ViewGraph& view_graph,
                                       const WeightedGraph& graph,
                                       const CommunityPartition& partition,
                                       const int image_overlap) {
  CommunityImages groups;
  groups.own_image_ids.resize(partition.NumCommunities());
  groups.image_names.resize(partition.NumCommunities());
  for (size_t vertex = 0; vertex < view_graph.NumVertices(); ++vertex) {
    const image_t image_id = view_graph.ImageIds()[vertex];
    groups.own_image_ids[partition.membership[vertex]].insert(image_id);
    groups.name_of_image.emplace(image_id, view_graph.ImageNames()[vertex]);
  }
  const std::vector<std::vector<int>> extended =
      ExtendCommunities(graph, partition, image_overlap);
  for (size_t community = 0; community < extended.size(); ++community) {
    for (const int vertex : extended[community]) {
      groups.image_names[community].insert(view_graph.ImageNames()[vertex]);
    }
  }
  return groups;
}

// IncrementalMapperController::Run, with the database loaded under
// `database_mutex`: COLMAP's Database sets no busy timeout, so two workers
// opening it at the same moment fail with "database is locked" and their
// communities would be lost.
void RunIncrementalMapper(IncrementalMapperController* mapper,
                          std::mutex* database_mutex) {
  {
    std::lock_guard<std::mutex> lock(*database_mutex);
    if (!mapper->LoadDatabase()) {
      return;
    }
  }
  // As upstream: where no initial pair is found, relax the constraints.
  IncrementalMapper::Options init_options = mapper->Options()->Mapper();
  mapper->Reconstruct(init_options);
  constexpr int kNumInitRelaxations = 2;
  for (int i = 0;
       i < kNumInitRelaxations && mapper->ReconstructionManager()->Size() == 0;
       ++i) {
    init_options.init_min_num_inliers /= 2;
    mapper->Reconstruct(init_options);
    if (mapper->ReconstructionManager()->Size() > 0) {
      break;
    }
    init_options.init_min_tri_angle /= 2;
    mapper->Reconstruct(init_options);
  }
}

// Reconstructs every community with COLMAP's incremental mapper, several at
// once, largest first. A community yielding several models keeps the
// largest; one yielding none gets nullptr. Models are written to
// output_path/communities/K as they finish (if output_path is set).
Models ReconstructCommunities(const CommunityMapperController::Options& options,
                              const CommunityImages& communities,
                              CommunityMapperController::Summary* summary) {
  const int num_communities =
      static_cast<int>(communities.own_image_ids.size());
  const int num_threads = GetEffectiveNumThreads(-1);
  const int num_workers =
      options.num_workers > 0
          ? options.num_workers
          : std::max(1, std::min(num_communities, num_threads));
  const int num_threads_per_worker = std::max(1, num_threads / num_workers);
  LOG(INFO) << StringPrintf(
      "Reconstructing %d communities with %d workers, %d threads each",
      num_communities,
      num_workers,
      num_threads_per_worker);

  const std::string communities_path =
      options.output_path.empty()
          ? ""
          : JoinPaths(options.output_path, "communities");
  if (!communities_path.empty()) {
    CreateDirIfNotExists(communities_path);
  }

  Models models(num_communities);
  summary->community_reports.assign(num_communities, CommunityModelReport());
  for (int c = 0; c < num_communities; ++c) {
    summary->community_reports[c].num_images =
        static_cast<int>(communities.image_names[c].size());
  }
  std::mutex summary_mutex;
  std::mutex database_mutex;

  auto reconstruct = [&](const int community) {
    ScopedLogTag log_tag(StringPrintf("community %d", community));
    try {
      auto incremental_options = std::make_shared<IncrementalMapperOptions>(
          options.CommunityIncrementalOptions(
              communities.image_names[community], num_threads_per_worker));
      LOG(INFO) << StringPrintf(
          "Reconstructing community %d (%d images, %d shared with "
          "neighbours)",
          community,
          static_cast<int>(communities.own_image_ids[community].size()),
          static_cast<int>(communities.image_names[community].size() -
                           communities.own_image_ids[community].size()));
      auto reconstruction_manager = std::make_shared<ReconstructionManager>();
      IncrementalMapperController mapper(std::move(incremental_options),
                                         options.image_path,
                                         options.database_path,
                                         reconstruction_manager);
      RunIncrementalMapper(&mapper, &database_mutex);

      std::shared_ptr<Reconstruction> largest;
      for (size_t i = 0; i < reconstruction_manager->Size(); ++i) {
        const auto& reconstruction = reconstruction_manager->Get(i);
        if (!largest ||
            reconstruction->NumRegImages() > largest->NumRegImages()) {
          largest = reconstruction;
        }
      }
      const int num_images =
          static_cast<int>(communities.image_names[community].size());
      if (!largest || largest->NumRegImages() == 0) {
        LOG(WARNING) << StringPrintf(
            "Community %d (%d images) could not be reconstructed; it takes no "
            "part in the merge.",
            community,
            num_images);
        return;
      }
      if (reconstruction_manager->Size() > 1) {
        LOG(WARNING) << StringPrintf(
            "Community %d broke into %d models; the largest (%d of %d "
            "images) takes part in the merge.",
            community,
            static_cast<int>(reconstruction_manager->Size()),
            static_cast<int>(largest->NumRegImages()),
            num_images);
      }
      if (!communities_path.empty()) {
        const std::string path =
            JoinPaths(communities_path, std::to_string(community));
        try {
          WriteReconstructionAtomically(*largest, path);
        } catch (const std::exception& error) {
          LOG(WARNING) << "Could not write " << path << ": " << error.what()
                       << "; the community still takes part in the merge.";
        }
      }
      LOG(INFO) << StringPrintf(
          "Community %d done: %d of %d images registered, %d points",
          community,
          static_cast<int>(largest->NumRegImages()),
          num_images,
          static_cast<int>(largest->NumPoints3D()));

      std::lock_guard<std::mutex> lock(summary_mutex);
      models[community] = largest;
      CommunityModelReport& report = summary->community_reports[community];
      report.num_registered = static_cast<int>(largest->NumRegImages());
      report.num_models = static_cast<int>(reconstruction_manager->Size());
      report.mean_reprojection_error = largest->ComputeMeanReprojectionError();
    } catch (const std::exception& error) {
      LOG(ERROR) << StringPrintf(
          "Community %d failed: %s; it takes no part in the merge.",
          community,
          error.what());
    }
  };

  // Communities are numbered largest first, the order that keeps the
  // workers busiest.
  ThreadPool thread_pool(num_workers);
  for (int community = 0; community < num_communities; ++community) {
    thread_pool.AddTask(reconstruct, community);
  }
  thread_pool.Wait();
  return models;
}

// View-graph edges between communities, by community pair (the smaller id
// first), each as the pair of its images in that order.
using CrossEdges =
    std::map<std::pair<int, int>, std::vector<std::pair<image_t, image_t>>>;

CrossEdges GroupCrossEdges(const ViewGraph& view_graph,
                           const CommunityPartition& partition) {
  CrossEdges cross_edges;
  for (const ViewGraph::Edge& edge : view_graph.Edges()) {
    int community1 = partition.membership[edge.vertex1];
    int community2 = partition.membership[edge.vertex2];
    image_t image_id1 = view_graph.ImageIds()[edge.vertex1];
    image_t image_id2 = view_graph.ImageIds()[edge.vertex2];
    if (community1 == community2) {
      continue;
    }
    if (community1 > community2) {
      std::swap(community1, community2);
      std::swap(image_id1, image_id2);
    }
    cross_edges[{community1, community2}].emplace_back(image_id1, image_id2);
  }
  return cross_edges;
}

// The pairwise similarity of every pair of reconstructed communities joined
// by view-graph edges, from the verified matches of those edges.
// The 3D points (ids in the models of the smaller and of the larger
// community) that the matches of one cross pair link, by image pair.
using CrossPairPoints =
    std::unordered_map<image_pair_t,
                       std::vector<std::pair<point3D_t, point3D_t>>>;

std::vector<RelativeSimilarity> EstimatePairwiseSimilarities(
    const CommunityMapperController::Options& options,
    const ViewGraph& view_graph,
    const CrossEdges& cross_edges,
    const Models& models,
    std::vector<std::vector<std::pair<point3D_t, point3D_t>>>*
        inlier_point3D_ids,
    CrossPairPoints* cross_pair_points,
    std::unordered_set<image_pair_t>* false_pairs,
    CommunityMapperController::Summary* summary) {
  summary->num_community_pairs = static_cast<int>(cross_edges.size());

  const Database database(options.database_path);
  std::vector<RelativeSimilarity> similarities;
  std::unordered_set<image_pair_t> verified_pairs;
  for (const ViewGraph::Edge& edge : view_graph.Edges()) {
    verified_pairs.insert(
        Database::ImagePairToPairId(view_graph.ImageIds()[edge.vertex1],
                                    view_graph.ImageIds()[edge.vertex2]));
  }
  const auto is_verified_pair = [&verified_pairs](const image_t image_id1,
                                                  const image_t image_id2) {
    return verified_pairs.count(
               Database::ImagePairToPairId(image_id1, image_id2)) > 0;
  };
  for (const auto& pair_and_edges : cross_edges) {
    const int community1 = pair_and_edges.first.first;
    const int community2 = pair_and_edges.first.second;
    if (!models[community1] || !models[community2]) {
      continue;
    }
    // Images on the border that both reconstructions registered: each of
    // their keypoints with a 3D point in both is a correspondence.
    const Reconstruction& model1 = *models[community1];
    const Reconstruction& model2 = *models[community2];
    std::vector<CrossPairMatches> cross_pairs;
    for (const image_t image_id : model1.RegImageIds()) {
      if (model2.ExistsImage(image_id) && model2.IsImageRegistered(image_id)) {
        CrossPairMatches shared;
        shared.image_id1 = image_id;
        shared.image_id2 = image_id;
        for (point2D_t idx = 0; idx < model1.Image(image_id).NumPoints2D();
             ++idx) {
          shared.matches.emplace_back(idx, idx);
        }
        cross_pairs.push_back(std::move(shared));
      }
    }
    const int num_shared_images = static_cast<int>(cross_pairs.size());
    for (const auto& image_pair : pair_and_edges.second) {
      CrossPairMatches cross_pair;
      cross_pair.image_id1 = image_pair.first;
      cross_pair.image_id2 = image_pair.second;
      cross_pair.matches =
          database.ReadTwoViewGeometry(image_pair.first, image_pair.second)
              .inlier_matches;
      const PointCorrespondences pair_points =
          FindPointCorrespondences(model1, model2, {cross_pair});
      auto& points = (*cross_pair_points)[Database::ImagePairToPairId(
          image_pair.first, image_pair.second)];
      for (size_t i = 0; i < pair_points.Size(); ++i) {
        points.emplace_back(pair_points.point3D_ids1[i],
                            pair_points.point3D_ids2[i]);
      }
      cross_pairs.push_back(std::move(cross_pair));
    }
    const PointCorrespondences correspondences =
        FindPointCorrespondences(model1, model2, cross_pairs);
    // Every transform is checked against the matches it implies; one that
    // contradicts them gives way to the next best.
    CovisibilityCheck covisibility;
    std::set<std::pair<point3D_t, point3D_t>> rejected_inliers;
    std::string rejected_checks;
    int num_rejected = 0;
    const PairwiseSimilarity similarity = EstimatePairwiseSimilarity(
        correspondences,
        options.pairwise_similarity,
        [&](const PairwiseSimilarity& candidate) {
          covisibility = CheckCovisibility(model1,
                                           model2,
                                           candidate.second_from_first,
                                           is_verified_pair,
                                           options.covisibility_check);
          if (!covisibility.consistent) {
            rejected_inliers.insert(candidate.inlier_point3D_ids.begin(),
                                    candidate.inlier_point3D_ids.end());
            rejected_checks += StringPrintf(
                " [%d inliers rejected: co-visible pairs verified %d of %d "
                "across, %d of %d inside]",
                candidate.num_inliers,
                covisibility.num_verified_cross_pairs,
                covisibility.num_predicted_cross_pairs,
                covisibility.num_verified_internal_pairs,
                covisibility.num_predicted_internal_pairs);
          }
          return covisibility.consistent;
        },
        &num_rejected);
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: %d shared images, %d cross edges, %d point "
        "correspondences%s -> %s",
        community1,
        community2,
        num_shared_images,
        static_cast<int>(pair_and_edges.second.size()),
        static_cast<int>(correspondences.Size()),
        rejected_checks.c_str(),
        similarity.success
            ? StringPrintf("%d inliers, scale %.4f, co-visible pairs "
                           "verified %d of %d across, %d of %d inside: used",
                           similarity.num_inliers,
                           similarity.second_from_first.scale,
                           covisibility.num_verified_cross_pairs,
                           covisibility.num_predicted_cross_pairs,
                           covisibility.num_verified_internal_pairs,
                           covisibility.num_predicted_internal_pairs)
                  .c_str()
        : num_rejected > 0 ? "no transform explains the matches, not used"
                           : "too little support, not used");
    // The cross pairs whose matches mostly support a rejected transform
    // (matches between two identical facades) are false: the merged
    // model's refinement leaves them out, where it would re-introduce them
    // as tracks (on generated landmarks with identical towers they took the
    // median camera error from 0.03 to 0.19 m).
    if (!rejected_inliers.empty()) {
      for (const auto& image_pair : pair_and_edges.second) {
        const image_pair_t pair_id =
            Database::ImagePairToPairId(image_pair.first, image_pair.second);
        const auto& points = cross_pair_points->at(pair_id);
        size_t num_rejected_points = 0;
        for (const auto& point_pair : points) {
          num_rejected_points += rejected_inliers.count(point_pair);
        }
        if (2 * num_rejected_points > points.size()) {
          false_pairs->insert(pair_id);
        }
      }
    }
    if (!similarity.success) {
      continue;
    }
    RelativeSimilarity relative;
    relative.community1 = community1;
    relative.community2 = community2;
    relative.second_from_first = similarity.second_from_first;
    relative.points1 = similarity.inlier_points1;
    relative.points2 = similarity.inlier_points2;
    relative.num_inliers = similarity.num_inliers;
    similarities.push_back(std::move(relative));
    inlier_point3D_ids->push_back(similarity.inlier_point3D_ids);
  }
  summary->num_estimated_similarities = static_cast<int>(similarities.size());
  return similarities;
}

// Joins the communities of one part (connected by kept similarities) into
// one model in the global frame, merges their corresponding points and
// refines the result on the part's images plus `extra_image_names` (images
// of communities that could not be reconstructed, which the refinement
// tries to register). The communities' own models are consumed. Adds the
// seconds spent in the refinement to `refinement_seconds`.
std::shared_ptr<Reconstruction> MergePart(
    const CommunityMapperController::Options& options,
    const std::vector<int>& part_communities,
    const CommunityImages& communities,
    const std::vector<RelativeSimilarity>& similarities,
    const std::vector<std::vector<std::pair<point3D_t, point3D_t>>>&
        inlier_point3D_ids,
    const SimilarityAveragingResult& averaging,
    const std::unordered_set<std::string>& extra_image_names,
    const std::unordered_set<image_pair_t>& false_pairs,
    Models* models,
    double* refinement_seconds) {
  LOG(INFO) << "Merging communities" << [&] {
    std::string ids;
    for (const int c : part_communities) ids += " " + std::to_string(c);
    return ids;
  }();
  std::vector<Reconstruction*> part_models;
  std::vector<Sim3d> world_from_community;
  std::vector<std::unordered_set<image_t>> owned_image_ids;
  std::unordered_set<std::string> part_image_names = extra_image_names;
  std::map<int, size_t> index_in_part;
  std::unordered_map<image_t, int> community_of_image;
  for (const int c : part_communities) {
    for (const image_t image_id : communities.own_image_ids[c]) {
      community_of_image.emplace(image_id, c);
    }
    index_in_part.emplace(c, part_models.size());
    part_models.push_back((*models)[c].get());
    world_from_community.push_back(averaging.world_from_community[c]);
    owned_image_ids.push_back(communities.own_image_ids[c]);
    for (const image_t image_id : communities.own_image_ids[c]) {
      part_image_names.insert(communities.name_of_image.at(image_id));
    }
  }
  std::shared_ptr<DatabaseCache> database_cache;
  {
    const Database database(options.database_path);
    database_cache = DatabaseCache::Create(
        database,
        static_cast<size_t>(options.incremental_options.min_num_matches),
        options.incremental_options.ignore_watermarks,
        part_image_names,
        [&false_pairs](const image_t image_id1, const image_t image_id2) {
          return false_pairs.count(
                     Database::ImagePairToPairId(image_id1, image_id2)) == 0;
        });
  }
  // An image left without any pair (all contradicting the merge) cannot be
  // refined: it stays out.
  for (std::unordered_set<image_t>& image_ids : owned_image_ids) {
    for (auto it = image_ids.begin(); it != image_ids.end();) {
      if (database_cache->ExistsImage(*it)) {
        ++it;
      } else {
        LOG(WARNING) << "Image " << communities.name_of_image.at(*it)
                     << " has no image pair left in the merged model; it is "
                        "left out.";
        it = image_ids.erase(it);
      }
    }
  }
  auto merged = std::make_shared<Reconstruction>();
  std::vector<std::unordered_map<point3D_t, point3D_t>> point3D_ids;
  JoinReconstructions(part_models,
                      world_from_community,
                      owned_image_ids,
                      merged.get(),
                      &point3D_ids);
  for (const int c : part_communities) {
    (*models)[c].reset();  // Joined: the community's copy is not needed.
  }

  std::vector<std::pair<point3D_t, point3D_t>> corresponding_points;
  for (size_t e = 0; e < similarities.size(); ++e) {
    if (!averaging.edges[e].kept ||
        averaging.part_of_community[similarities[e].community1] !=
            averaging.part_of_community[part_communities[0]]) {
      continue;
    }
    const auto& ids1 =
        point3D_ids[index_in_part.at(similarities[e].community1)];
    const auto& ids2 =
        point3D_ids[index_in_part.at(similarities[e].community2)];
    for (const auto& pair : inlier_point3D_ids[e]) {
      const auto it1 = ids1.find(pair.first);
      const auto it2 = ids2.find(pair.second);
      if (it1 != ids1.end() && it2 != ids2.end()) {
        corresponding_points.emplace_back(it1->second, it2->second);
      }
    }
  }
  const size_t num_merged_points =
      MergeCorrespondingPoints(corresponding_points, merged.get());
  LOG(INFO) << StringPrintf(
      "Joined %d images and %d points; merged %d corresponding points",
      static_cast<int>(merged->NumRegImages()),
      static_cast<int>(merged->NumPoints3D()),
      static_cast<int>(num_merged_points));

  Timer timer;
  timer.Start();
  const MergedModelRefinementSummary refinement =
      RefineMergedModel(options.refinement,
                        options.incremental_options,
                        std::move(database_cache),
                        community_of_image,
                        merged);
  *refinement_seconds += timer.ElapsedSeconds();
  LOG(INFO) << StringPrintf(
      "Merged model: %d images, %d points, mean reprojection error %.3f px "
      "(%.3f px before refinement), %d images newly registered",
      static_cast<int>(merged->NumRegImages()),
      static_cast<int>(merged->NumPoints3D()),
      refinement.final_mean_reprojection_error,
      refinement.initial_mean_reprojection_error,
      refinement.num_newly_registered_images);
  if (options.incremental_options.extract_colors) {
    merged->ExtractColorsForAllImages(options.image_path);
  }
  return merged;
}

// The closing summary of a run.
void LogSummary(const CommunityMapperController::Summary& summary) {
  PrintHeading1("Community mapper summary");
  for (size_t c = 0; c < summary.community_sizes.size(); ++c) {
    const CommunityModelReport& report = summary.community_reports[c];
    LOG(INFO) << StringPrintf(
        "Community %d: %d images, %d registered%s%s",
        static_cast<int>(c),
        summary.community_sizes[c],
        report.num_registered,
        report.num_models > 1 ? " (largest of several models)" : "",
        summary.community_excluded[c] ? ", left the merge" : "");
  }
  LOG(INFO) << StringPrintf(
      "Community pairs: %d joined by view-graph edges, %d with a similarity, "
      "%d kept, %d dropped",
      summary.num_community_pairs,
      summary.num_estimated_similarities,
      summary.num_kept_similarities,
      summary.num_estimated_similarities - summary.num_kept_similarities);
  int num_registered = 0;
  for (size_t m = 0; m < summary.model_num_registered.size(); ++m) {
    LOG(INFO) << StringPrintf("Model %d: %d images",
                              static_cast<int>(m),
                              summary.model_num_registered[m]);
    num_registered += summary.model_num_registered[m];
  }
  LOG(INFO) << StringPrintf(
      "Registered %d of %d images in %d model(s)",
      num_registered,
      summary.num_view_graph_images,
      static_cast<int>(summary.model_num_registered.size()));
  for (const auto& phase : summary.phase_seconds) {
    LOG(INFO) << StringPrintf(
        "Time %-28s %9.3fs", (phase.first + ":").c_str(), phase.second);
  }
}

}  // namespace

int CommunityMapperController::Options::MinNumMatches() const {
  return min_num_matches > 0 ? min_num_matches
                             : incremental_options.min_num_matches;
}

IncrementalMapperOptions
CommunityMapperController::Options::CommunityIncrementalOptions(
    const std::unordered_set<std::string>& image_names,
    const int num_threads) const {
  IncrementalMapperOptions community_options = incremental_options;
  community_options.image_names = image_names;
  if (community_options.num_threads < 0) {
    community_options.num_threads = num_threads;
  }
  if (community_ba_function_tolerance >= 0) {
    community_options.ba_global_function_tolerance =
        community_ba_function_tolerance;
  }
  if (community_ba_global_ratio > 0) {
    community_options.ba_global_images_ratio = community_ba_global_ratio;
    community_options.ba_global_points_ratio = community_ba_global_ratio;
  }
  return community_options;
}

bool CommunityMapperController::Options::Check() const {
  CHECK_OPTION(community_detection.Check());
  CHECK_OPTION(min_num_matches == -1 || min_num_matches > 0);
  CHECK_OPTION(edge_weights == "unit" || edge_weights == "num_inliers");
  CHECK_OPTION_GE(image_overlap, 0);
  CHECK_OPTION_GE(num_workers, -1);
  CHECK_OPTION_NE(num_workers, 0);
  CHECK_OPTION(community_ba_function_tolerance == -1 ||
               community_ba_function_tolerance >= 0);
  CHECK_OPTION(community_ba_global_ratio == -1 ||
               community_ba_global_ratio > 1);
  CHECK_OPTION(pairwise_similarity.Check());
  CHECK_OPTION(covisibility_check.Check());
  CHECK_OPTION(similarity_averaging.Check());
  CHECK_OPTION(refinement.Check());
  CHECK_OPTION(incremental_options.Check());
  return true;
}

CommunityMapperController::CommunityMapperController(
    const Options& options,
    std::shared_ptr<ReconstructionManager> reconstruction_manager)
    : options_(options),
      reconstruction_manager_(std::move(reconstruction_manager)) {
  THROW_CHECK(options_.Check());
}

void CommunityMapperController::Run() {
  Timer run_timer;
  run_timer.Start();
  summary_ = Summary();
  Timer phase_timer;
  auto end_phase = [&](const std::string& name) {
    summary_.phase_seconds.emplace_back(name, phase_timer.ElapsedSeconds());
    LOG(INFO) << StringPrintf(
        "%s: %.3fs", name.c_str(), phase_timer.ElapsedSeconds());
  };

  //////////////////////////////////////////////////////////////////////////////
  // 1. View graph and communities
  //////////////////////////////////////////////////////////////////////////////

  PrintHeading1("1. Partitioning the view graph into communities");
  phase_timer.Start();

  const ViewGraphEdgeWeight edge_weight =
      ViewGraphEdgeWeightFromString(options_.edge_weights);
  const ViewGraph view_graph = ViewGraph::Read(Database(options_.database_path),
                                               options_.MinNumMatches());
  const WeightedGraph graph = view_graph.ToWeightedGraph(edge_weight);
  const std::vector<std::vector<int>> components = graph.ConnectedComponents();
  summary_.num_view_graph_images = static_cast<int>(view_graph.NumVertices());
  summary_.num_view_graph_edges = static_cast<int>(view_graph.NumEdges());
  summary_.num_view_graph_components = static_cast<int>(components.size());
  LOG(INFO) << StringPrintf(
      "View graph: %d images, %d edges (>= %d inlier matches), %d connected "
      "component(s), the largest with %d images",
      summary_.num_view_graph_images,
      summary_.num_view_graph_edges,
      options_.MinNumMatches(),
      summary_.num_view_graph_components,
      components.empty() ? 0 : static_cast<int>(components[0].size()));
  if (view_graph.NumEdges() == 0) {
    LOG(ERROR) << "The database has no verified image pairs with at least "
               << options_.MinNumMatches()
               << " inlier matches: run a matcher first.";
    return;
  }

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), options_.community_detection);
  const CommunityImages communities = GroupImagesByCommunity(
      view_graph, graph, partition, options_.image_overlap);
  summary_.max_modularity = partition.MaxModularity();
  for (size_t vertex = 0; vertex < view_graph.NumVertices(); ++vertex) {
    summary_.community_of_image.emplace(view_graph.ImageIds()[vertex],
                                        partition.membership[vertex]);
  }
  std::string sizes;
  for (const auto& image_ids : communities.own_image_ids) {
    summary_.community_sizes.push_back(static_cast<int>(image_ids.size()));
    sizes += " " + std::to_string(image_ids.size());
  }
  LOG(INFO) << StringPrintf(
      "%d communities (%d before merging those under %d images), sizes:%s",
      partition.NumCommunities(),
      partition.num_communities_before_merge,
      options_.community_detection.min_community_size,
      sizes.c_str());
  if (!options_.output_path.empty()) {
    const std::string path = JoinPaths(options_.output_path, "communities.txt");
    WriteTextFileAtomically(
        CommunitiesToText(view_graph,
                          partition,
                          options_.community_detection.modularity_threshold,
                          edge_weight),
        path);
    LOG(INFO) << "Wrote " << path;
  }
  end_phase("Partition");
  if (options_.partition_only) {
    run_timer.PrintMinutes();
    return;
  }

  //////////////////////////////////////////////////////////////////////////////
  // 2. Community reconstruction
  //////////////////////////////////////////////////////////////////////////////

  PrintHeading1("2. Reconstructing the communities");
  phase_timer.Restart();
  Models models = ReconstructCommunities(options_, communities, &summary_);
  end_phase("Communities");
  if (CheckIfStopped()) {
    return;
  }

  //////////////////////////////////////////////////////////////////////////////
  // 3. Pairwise similarities and global similarity averaging
  //////////////////////////////////////////////////////////////////////////////

  PrintHeading1("3. Global similarity averaging");
  phase_timer.Restart();
  std::vector<std::vector<std::pair<point3D_t, point3D_t>>> inlier_point3D_ids;
  std::unordered_set<image_pair_t> false_pairs;
  CrossPairPoints cross_pair_points;
  const CrossEdges cross_edges = GroupCrossEdges(view_graph, partition);
  const std::vector<RelativeSimilarity> similarities =
      EstimatePairwiseSimilarities(options_,
                                   view_graph,
                                   cross_edges,
                                   models,
                                   &inlier_point3D_ids,
                                   &cross_pair_points,
                                   &false_pairs,
                                   &summary_);
  summary_.community_judgements =
      JudgeCommunityModels(summary_.community_reports, options_.judgement);
  std::vector<AveragedCommunity> averaged_communities(models.size());
  for (size_t c = 0; c < models.size(); ++c) {
    averaged_communities[c].num_images =
        summary_.community_reports[c].num_registered;
    averaged_communities[c].doubtful =
        summary_.community_judgements[c].doubtful;
    averaged_communities[c].excluded = summary_.community_judgements[c].broken;
  }
  const SimilarityAveragingResult averaging = AverageSimilarities(
      averaged_communities, similarities, options_.similarity_averaging);
  cross_pair_points.clear();
  for (size_t c = 0; c < models.size(); ++c) {
    const CommunityJudgement& judgement = summary_.community_judgements[c];
    if (judgement.broken || judgement.doubtful) {
      LOG(WARNING) << StringPrintf(
          "Community %d is %s (%s)%s",
          static_cast<int>(c),
          judgement.broken ? "broken" : "in doubt",
          judgement.reason.c_str(),
          judgement.broken ? "" : ": it takes part with little weight.");
    }
  }
  summary_.community_excluded = averaging.excluded;
  for (size_t e = 0; e < similarities.size(); ++e) {
    const auto& report = averaging.edges[e];
    summary_.num_kept_similarities += report.kept ? 1 : 0;
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: residuals rotation %.3f deg, scale %.4f, "
        "translation %.4f -> %s",
        similarities[e].community1,
        similarities[e].community2,
        report.rotation_residual_deg,
        report.log_scale_residual,
        report.relative_translation_residual,
        report.kept ? "kept" : "dropped");
  }
  if (!false_pairs.empty()) {
    LOG(INFO) << StringPrintf(
        "%d image pairs between communities support only rejected "
        "transforms: the refinement leaves them out.",
        static_cast<int>(false_pairs.size()));
  }
  for (size_t c = 0; c < models.size(); ++c) {
    if (averaging.excluded[c]) {
      LOG(WARNING) << StringPrintf(
          "Community %d leaves the merge: %s. Its images are offered to the "
          "merged model.",
          static_cast<int>(c),
          summary_.community_judgements[c].broken ? "its model is broken"
          : summary_.community_judgements[c].doubtful
              ? "its similarities disagree with the other communities' "
                "and its model is in doubt"
              : "its similarities disagree with the other communities' "
                "and it is small");
      models[c].reset();
    }
  }
  end_phase("Similarity averaging");

  //////////////////////////////////////////////////////////////////////////////
  // 4. Merge and final bundle adjustment
  //////////////////////////////////////////////////////////////////////////////

  PrintHeading1("4. Merging the communities and bundle adjustment");
  phase_timer.Restart();
  // The images of a community without a model are offered to the part its
  // view-graph edges lead to most, whose refinement registers those it can.
  std::map<int, std::map<int, size_t>> num_edges_to_part;
  for (const auto& pair_and_edges : cross_edges) {
    const int community1 = pair_and_edges.first.first;
    const int community2 = pair_and_edges.first.second;
    if (!models[community1] != !models[community2]) {
      const int unmodelled = models[community1] ? community2 : community1;
      const int modelled = models[community1] ? community1 : community2;
      num_edges_to_part[unmodelled][averaging.part_of_community[modelled]] +=
          pair_and_edges.second.size();
    }
  }
  std::map<int, std::unordered_set<std::string>> unmodelled_images_of_part;
  for (const auto& community_and_counts : num_edges_to_part) {
    const auto& counts = community_and_counts.second;
    const int best_part = std::max_element(counts.begin(),
                                           counts.end(),
                                           [](const auto& a, const auto& b) {
                                             return a.second < b.second;
                                           })
                              ->first;
    for (const image_t image_id :
         communities.own_image_ids[community_and_counts.first]) {
      unmodelled_images_of_part[best_part].insert(
          communities.name_of_image.at(image_id));
    }
  }
  double refinement_seconds = 0.0;
  std::vector<std::shared_ptr<Reconstruction>> merged_models;
  for (int part = 0; part < averaging.NumParts(); ++part) {
    std::vector<int> part_communities;
    for (size_t c = 0; c < models.size(); ++c) {
      if (averaging.part_of_community[c] == part && models[c]) {
        part_communities.push_back(static_cast<int>(c));
      }
    }
    if (part_communities.empty()) {
      continue;
    }
    // A part of one community is taken as it is, unless images of
    // communities without a model are offered to it.
    if (part_communities.size() == 1 &&
        unmodelled_images_of_part[part].empty()) {
      const int c = part_communities[0];
      std::shared_ptr<Reconstruction> model =
          RestrictToImages(communities.own_image_ids[c], models[c]);
      models[c].reset();
      if (model->NumRegImages() < 2) {
        LOG(WARNING) << StringPrintf(
            "Community %d, alone in its part, registered fewer than 2 of its "
            "own images: no model for it.",
            c);
        continue;
      }
      merged_models.push_back(std::move(model));
      continue;
    }

    try {
      merged_models.push_back(MergePart(options_,
                                        part_communities,
                                        communities,
                                        similarities,
                                        inlier_point3D_ids,
                                        averaging,
                                        unmodelled_images_of_part[part],
                                        false_pairs,
                                        &models,
                                        &refinement_seconds));
    } catch (const std::exception& error) {
      // Nothing is lost: the part's communities, as written when they were
      // done, become models of their own.
      LOG(ERROR) << "Merging communities failed: " << error.what()
                 << "; each of them is written as a model of its own.";
      for (const int c : part_communities) {
        const std::string path =
            options_.output_path.empty()
                ? ""
                : JoinPaths(
                      options_.output_path, "communities", std::to_string(c));
        if (path.empty() || !ExistsDir(path)) {
          continue;
        }
        auto model = std::make_shared<Reconstruction>();
        model->Read(path);
        model = RestrictToImages(communities.own_image_ids[c], model);
        if (model->NumRegImages() >= 2) {
          merged_models.push_back(std::move(model));
        }
      }
    }
  }

  std::stable_sort(merged_models.begin(),
                   merged_models.end(),
                   [](const std::shared_ptr<Reconstruction>& a,
                      const std::shared_ptr<Reconstruction>& b) {
                     return a->NumRegImages() > b->NumRegImages();
                   });
  for (const auto& model : merged_models) {
    summary_.model_num_registered.push_back(
        static_cast<int>(model->NumRegImages()));
    reconstruction_manager_->Get(reconstruction_manager_->Add()) = model;
  }
  if (!options_.output_path.empty() && !merged_models.empty()) {
    const std::string path = JoinPaths(options_.output_path, "communities.ply");
    try {
      WriteTextFileAtomically(
          CommunityCamerasToPly(*merged_models[0], summary_.community_of_image),
          path);
    } catch (const std::exception& error) {
      LOG(WARNING) << "Could not write " << path << ": " << error.what();
    }
  }
  // The merge (joining the models, merging their points, loading the
  // correspondences, colours) and the final bundle adjustment (with the
  // registration of left-over images, track completion and filtering) are
  // reported apart.
  const double merge_total = phase_timer.ElapsedSeconds();
  summary_.phase_seconds.emplace_back("Merge",
                                      merge_total - refinement_seconds);
  summary_.phase_seconds.emplace_back("Final bundle adjustment",
                                      refinement_seconds);
  LOG(INFO) << StringPrintf("Merge: %.3fs, final bundle adjustment: %.3fs",
                            merge_total - refinement_seconds,
                            refinement_seconds);

  //////////////////////////////////////////////////////////////////////////////
  // Summary
  //////////////////////////////////////////////////////////////////////////////

  LogSummary(summary_);
  run_timer.PrintMinutes();
}

}  // namespace colmap
