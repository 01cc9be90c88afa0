#include "colmap_ext/controllers/community_mapper.h"

#include "colmap_ext/scene/community_io.h"
#include "colmap_ext/sfm/community_alignment.h"
#include "colmap_ext/sfm/community_reconstruction.h"
#include "colmap_ext/sfm/part_offers.h"
#include "colmap_ext/util/atomic_output.h"
#include "colmap_ext/util/database_retry.h"
#include "colmap_ext/util/log_tag.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/math/math.h"
#include "colmap/math/random.h"
#include "colmap/scene/database.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/misc.h"
#include "colmap/util/threading.h"
#include "colmap/util/timer.h"

#include <algorithm>
#include <map>
#include <set>

namespace colmap {
namespace {

using Models = std::vector<std::shared_ptr<Reconstruction>>;

// The database's fingerprint (community_workspace.h), its opening tried
// again while another task of a job array holds the database
// (database_retry.h).
std::string ReadDatabaseFingerprint(const std::string& database_path) {
  std::string fingerprint;
  RetryDatabaseAccessOrThrow(database_path, [&]() {
    fingerprint = DatabaseFingerprint(Database(database_path));
  });
  return fingerprint;
}

// The fraction of `image_names` whose camera no other image of the database
// uses. The reading is tried again while another process holds the database
// (database_retry.h), as the community's loading is: a community's settings
// must not depend on whether the database was locked a moment.
double OwnCameraFraction(const std::string& database_path,
                         const std::unordered_set<std::string>& image_names,
                         std::mutex* database_mutex) {
  std::vector<Image> images;
  RetryDatabaseAccessOrThrow(database_path, [&]() {
    std::lock_guard<std::mutex> lock(*database_mutex);
    images = Database(database_path).ReadAllImages();
  });
  std::unordered_map<camera_t, int> num_images_of_camera;
  for (const Image& image : images) {
    ++num_images_of_camera[image.CameraId()];
  }
  int num_own = 0;
  int num_found = 0;
  for (const Image& image : images) {
    if (image_names.count(image.Name()) > 0) {
      ++num_found;
      num_own += num_images_of_camera.at(image.CameraId()) == 1 ? 1 : 0;
    }
  }
  return num_found == 0 ? 0.0 : static_cast<double>(num_own) / num_found;
}

// Where the memory stands after a step (for a long run's log).
void LogMemory(const std::string& step) {
  LOG(INFO) << "Memory after " << step << ": "
            << ProcessMemoryToString(ReadProcessMemory());
}

// The own images of every community, by the plan (the merge adds its extra
// communities).
struct CommunityImages {
  std::vector<std::unordered_set<image_t>> own_image_ids;
  std::unordered_map<image_t, std::string> name_of_image;
  std::unordered_map<image_t, int> community_of_image;
};

CommunityImages GroupImagesByCommunity(const ViewGraph& view_graph,
                                       const CommunityPlan& plan) {
  std::unordered_map<std::string, image_t> image_of_name;
  for (size_t vertex = 0; vertex < view_graph.NumVertices(); ++vertex) {
    image_of_name.emplace(view_graph.ImageNames()[vertex],
                          view_graph.ImageIds()[vertex]);
  }
  CommunityImages groups;
  groups.own_image_ids.resize(plan.NumCommunities());
  for (int c = 0; c < plan.NumCommunities(); ++c) {
    for (const std::string& name : plan.communities[c].own_image_names) {
      const image_t image_id = image_of_name.at(name);
      groups.own_image_ids[c].insert(image_id);
      groups.name_of_image.emplace(image_id, name);
      groups.community_of_image.emplace(image_id, c);
    }
  }
  return groups;
}

// Community `record.community_id`'s other models, as its stage wrote them
// into `workspace` (largest first), each become an extra community if they
// registered at least `min_model_size` of the community's own images that
// no larger model of it taking part did. The extra community, numbered after
// those in `models`, owns those images (the community keeps the others):
// its shape is the mapper's, joined by a similarity as any community's,
// instead of its images being registered anew one by one into the merged
// model. Its report and origin are added to `summary`.
void AddExtraCommunities(const CommunityWorkspace& workspace,
                         const CommunityRecord& record,
                         const int min_model_size,
                         CommunityImages* communities,
                         Models* models,
                         std::vector<std::string>* model_paths,
                         CommunityMapperController::Summary* summary) {
  const int c = record.community_id;
  std::unordered_set<image_t> taken_image_ids(
      (*models)[c]->RegImageIds().begin(), (*models)[c]->RegImageIds().end());
  for (int index = 1; index <= record.num_other_models; ++index) {
    auto other_model = std::make_shared<Reconstruction>();
    const std::string path = workspace.CommunityOtherModelPath(c, index);
    other_model->Read(path);
    std::unordered_set<image_t> owned_image_ids;
    for (const image_t image_id : other_model->RegImageIds()) {
      if (communities->own_image_ids[c].count(image_id) > 0 &&
          taken_image_ids.count(image_id) == 0) {
        owned_image_ids.insert(image_id);
      }
    }
    if (static_cast<int>(owned_image_ids.size()) < min_model_size) {
      LOG(INFO) << StringPrintf(
          "Community %d's model %d of %d holds %d of its own images that no "
          "larger model of it holds: too few to take part",
          c,
          index + 1,
          record.num_models,
          static_cast<int>(owned_image_ids.size()));
      continue;
    }
    taken_image_ids.insert(other_model->RegImageIds().begin(),
                           other_model->RegImageIds().end());
    const int extra = static_cast<int>(models->size());
    LOG(INFO) << StringPrintf(
        "Community %d's model %d of %d (%d images, %d of its own that no "
        "larger model of it holds) takes part as community %d",
        c,
        index + 1,
        record.num_models,
        static_cast<int>(other_model->NumRegImages()),
        static_cast<int>(owned_image_ids.size()),
        extra);
    for (const image_t image_id : owned_image_ids) {
      communities->own_image_ids[c].erase(image_id);
      communities->community_of_image[image_id] = extra;
    }
    communities->own_image_ids.push_back(std::move(owned_image_ids));
    CommunityModelReport report = summary->community_reports[c];
    report.num_registered = static_cast<int>(other_model->NumRegImages());
    report.mean_reprojection_error =
        other_model->ComputeMeanReprojectionError();
    report.model_index = index + 1;
    summary->community_reports.push_back(report);
    summary->extra_community_origins.push_back(c);
    models->push_back(std::move(other_model));
    model_paths->push_back(path);
  }
}

// The images of `image_ids` that are not in `taken_image_ids`.
template <typename ImageIds>
std::unordered_set<image_t> ImagesNotTaken(
    const ImageIds& image_ids,
    const std::unordered_set<image_t>& taken_image_ids) {
  std::unordered_set<image_t> left_image_ids;
  for (const image_t image_id : image_ids) {
    if (taken_image_ids.count(image_id) == 0) {
      left_image_ids.insert(image_id);
    }
  }
  return left_image_ids;
}

// Joins the communities of one part (connected by kept similarities) into
// one model in the global frame, merges their corresponding points and
// refines the result on the part's own images plus `extra_image_names`
// (images of communities without a model or that left the merge, and of
// parts offered to this one, which the refinement tries to register). Own
// images in `taken_image_ids` (registered by an earlier part's model) are
// left out. `offered_models` are the models (their own images only) of the
// communities of parts offered to this one and of those offered to it
// that left the merge for want of a confirmed link, which the refinement
// registers as blocks where it can. The communities' own models are
// consumed. Adds the seconds spent in the refinement to
// `refinement_seconds`.
std::shared_ptr<Reconstruction> MergePart(
    const CommunityMapperController::Options& options,
    const std::vector<int>& part_communities,
    const CommunityImages& communities,
    const std::vector<RelativeSimilarity>& similarities,
    const SimilarityAveragingResult& averaging,
    const std::unordered_set<std::string>& extra_image_names,
    const std::unordered_set<image_t>& taken_image_ids,
    const std::unordered_set<image_pair_t>& false_pairs,
    const ViewGraph& view_graph,
    const std::vector<std::shared_ptr<const Reconstruction>>& offered_models,
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
    owned_image_ids.push_back(
        ImagesNotTaken(communities.own_image_ids[c], taken_image_ids));
    for (const image_t image_id : owned_image_ids.back()) {
      part_image_names.insert(communities.name_of_image.at(image_id));
    }
  }
  // An image left without any pair (all contradicting the merge) cannot be
  // refined: it stays out. (The view graph tells, before the models are
  // joined and released, which images the correspondences will hold.)
  std::unordered_set<image_t> connected_image_ids;
  for (const ViewGraph::Edge& edge : view_graph.Edges()) {
    const image_t image_id1 = view_graph.ImageIds()[edge.vertex1];
    const image_t image_id2 = view_graph.ImageIds()[edge.vertex2];
    if (part_image_names.count(view_graph.ImageNames()[edge.vertex1]) &&
        part_image_names.count(view_graph.ImageNames()[edge.vertex2]) &&
        !false_pairs.count(Database::ImagePairToPairId(image_id1, image_id2))) {
      connected_image_ids.insert(image_id1);
      connected_image_ids.insert(image_id2);
    }
  }
  for (std::unordered_set<image_t>& image_ids : owned_image_ids) {
    for (auto it = image_ids.begin(); it != image_ids.end();) {
      if (connected_image_ids.count(*it)) {
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
  if (options.align_pose_graph) {
    Timer timer;
    timer.Start();
    const PoseGraphAlignmentSummary pose_graph =
        AlignPoseGraph(std::vector<const Reconstruction*>(part_models.begin(),
                                                          part_models.end()),
                       owned_image_ids,
                       options.pose_graph,
                       merged.get());
    LOG(INFO) << StringPrintf(
        "Pose graph of %d cameras, %d edges, %d ties between the copies of "
        "one image (largest disagreement %.2f deg, %.2f edge lengths; %d "
        "dropped): cost %.4g -> %.4g, cameras moved by %.3f (median), %.3f "
        "(max) edge lengths (%.1fs)",
        pose_graph.num_images,
        pose_graph.num_edges,
        pose_graph.num_ties,
        pose_graph.max_tie_rotation_deg,
        pose_graph.max_tie_distance,
        pose_graph.num_dropped_ties,
        pose_graph.initial_cost,
        pose_graph.final_cost,
        pose_graph.median_relative_movement,
        pose_graph.max_relative_movement,
        timer.ElapsedSeconds());
  }
  for (const int c : part_communities) {
    (*models)[c].reset();  // Joined: the community's copy is not needed.
  }
  ReleaseFreedMemory();

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
    for (const auto& pair : similarities[e].point3D_ids) {
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
  LogMemory("joining the models");

  // The correspondences, once the communities' models are released and
  // the joined cameras aligned (RefineMergedModel).
  const auto load_correspondences = [&]() {
    std::shared_ptr<DatabaseCache> database_cache;
    {
      const Database database(options.database_path);
      database_cache = DatabaseCache::Create(
          database,
          static_cast<size_t>(options.MinNumMatches()),
          options.incremental_options.ignore_watermarks,
          part_image_names,
          [&false_pairs](const image_t image_id1, const image_t image_id2) {
            return false_pairs.count(
                       Database::ImagePairToPairId(image_id1, image_id2)) == 0;
          });
    }
    // Building the correspondence graph grows a vector per keypoint and
    // then flattens them; the freed vectors would stay resident through the
    // refinement (see ReleaseFreedMemory).
    ReleaseFreedMemory();
    for (const image_t image_id : merged->RegImageIds()) {
      THROW_CHECK(database_cache->ExistsImage(image_id))
          << "image " << merged->Image(image_id).Name()
          << " has no correspondences";
    }
    LogMemory("loading the correspondences");
    return std::shared_ptr<const DatabaseCache>(std::move(database_cache));
  };

  Timer timer;
  timer.Start();
  const MergedModelRefinementSummary refinement =
      RefineMergedModel(options.refinement,
                        options.incremental_options,
                        load_correspondences,
                        community_of_image,
                        offered_models,
                        merged);
  *refinement_seconds += timer.ElapsedSeconds();
  LogMemory("the refinement");
  LOG(INFO) << StringPrintf(
      "Merged model: %d images, %d points, mean reprojection error %.3f px "
      "(%.3f px before refinement), %d images newly registered (%d as "
      "blocks), %d misplaced ones registered again",
      static_cast<int>(merged->NumRegImages()),
      static_cast<int>(merged->NumPoints3D()),
      refinement.final_mean_reprojection_error,
      refinement.initial_mean_reprojection_error,
      refinement.num_newly_registered_images,
      refinement.num_block_registered_images,
      refinement.num_reregistered_images);
  if (options.incremental_options.extract_colors) {
    merged->ExtractColorsForAllImages(options.image_path);
  }
  return merged;
}

// The closing summary of a run.
void LogSummary(const CommunityMapperController::Summary& summary) {
  PrintHeading1("Community mapper summary");
  // (A merge that stopped early judged nothing.)
  const auto left_the_merge = [&summary](const size_t c) {
    return c < summary.community_excluded.size() &&
                   summary.community_excluded[c]
               ? ", left the merge"
               : "";
  };
  for (size_t c = 0; c < summary.community_sizes.size() &&
                     c < summary.community_reports.size();
       ++c) {
    const CommunityModelReport& report = summary.community_reports[c];
    LOG(INFO) << StringPrintf(
        "Community %d: %d images, %d registered%s%s",
        static_cast<int>(c),
        summary.community_sizes[c],
        report.num_registered,
        report.num_models > 1 ? " (largest of several models)" : "",
        left_the_merge(c));
  }
  for (size_t e = 0; e < summary.extra_community_origins.size(); ++e) {
    const size_t c = summary.community_sizes.size() + e;
    LOG(INFO) << StringPrintf(
        "Community %d (model %d of community %d): %d registered%s",
        static_cast<int>(c),
        summary.community_reports[c].model_index,
        summary.extra_community_origins[e],
        summary.community_reports[c].num_registered,
        left_the_merge(c));
  }
  LOG(INFO) << StringPrintf(
      "Community pairs: %d joined by view-graph edges, %d with a similarity, "
      "%d kept, %d dropped",
      summary.num_community_pairs,
      summary.num_estimated_similarities,
      summary.num_kept_similarities,
      summary.num_estimated_similarities - summary.num_kept_similarities);
  if (!summary.reused_communities.empty()) {
    std::string ids;
    for (const int c : summary.reused_communities) {
      ids += " " + std::to_string(c);
    }
    LOG(INFO) << "Communities reused from an earlier run of this plan:" << ids;
  }
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
  LOG(INFO) << StringPrintf("Peak memory: %.0f MB", summary.peak_memory_mb);
}

// The communities' models as their stage left them in `workspace` (none
// for a community that registered nothing), the plan's first, then, with
// `options.merge_other_models`, the extra communities (AddExtraCommunities),
// with their paths; their reports go to `summary`.
void ReadCommunityModels(const CommunityMapperController::Options& options,
                         const CommunityWorkspace& workspace,
                         const int num_plan_communities,
                         CommunityImages* communities,
                         Models* models_ptr,
                         std::vector<std::string>* model_paths,
                         CommunityMapperController::Summary* summary) {
  Models& models = *models_ptr;
  models.assign(num_plan_communities, nullptr);
  model_paths->clear();
  std::vector<CommunityRecord> records;
  summary->community_reports.assign(num_plan_communities,
                                    CommunityModelReport());
  for (int c = 0; c < num_plan_communities; ++c) {
    records.push_back(CommunityRecordFromText(
        ReadTextFile(workspace.CommunityRecordPath(c))));
    const CommunityRecord& record = records.back();
    CommunityModelReport& report = summary->community_reports[c];
    report.num_images = record.num_images;
    report.num_registered = record.num_registered;
    report.num_models = record.num_models;
    report.mean_reprojection_error = record.mean_reprojection_error;
    model_paths->push_back(workspace.CommunityModelPath(c));
    if (record.num_registered > 0) {
      models[c] = std::make_shared<Reconstruction>();
      models[c]->Read(model_paths->back());
    }
  }
  // Where a community's mapper made several models, the others take part
  // as extra communities (AddExtraCommunities).
  summary->extra_community_origins.clear();
  for (int c = 0; c < num_plan_communities; ++c) {
    if (models[c] && options.merge_other_models) {
      AddExtraCommunities(workspace,
                          records[c],
                          options.incremental_options.min_model_size,
                          communities,
                          models_ptr,
                          model_paths,
                          summary);
    }
  }
}

// Judges every community's own model (JudgeCommunityModels: broken ones
// leave the merge, doubtful ones count little) and averages the
// similarities between them; where rejected similarities may join parts
// (Options::join_parts_by_rejected_links), averages again with them, and
// those that join move from the rejected ones to the similarities (their
// pairs are no false pairs any more). Logs each link's residuals and fate.
// Fills the judgements and the links of `summary`.
SimilarityAveragingResult JudgeAndAverage(
    const CommunityMapperController::Options& options,
    CommunitySimilarities* community_similarities,
    CommunityMapperController::Summary* summary) {
  const int num_communities =
      static_cast<int>(summary->community_reports.size());
  summary->community_judgements =
      JudgeCommunityModels(summary->community_reports, options.judgement);
  std::vector<AveragedCommunity> averaged_communities(num_communities);
  for (int c = 0; c < num_communities; ++c) {
    const CommunityJudgement& judgement = summary->community_judgements[c];
    averaged_communities[c].num_images =
        summary->community_reports[c].num_registered;
    averaged_communities[c].doubtful = judgement.doubtful;
    averaged_communities[c].excluded = judgement.broken;
    if (judgement.broken || judgement.doubtful) {
      LOG(WARNING) << StringPrintf(
          "Community %d is %s (%s)%s",
          c,
          judgement.broken ? "broken" : "in doubt",
          judgement.reason.c_str(),
          judgement.broken ? "" : ": it takes part with little weight.");
    }
  }
  std::vector<RelativeSimilarity>& similarities =
      community_similarities->similarities;
  SimilarityAveragingResult averaging = AverageSimilarities(
      averaged_communities, similarities, options.similarity_averaging);
  std::vector<int> joined;
  if (options.join_parts_by_rejected_links &&
      JoinPartsByRejectedLinks(averaged_communities,
                               community_similarities->rejected_similarities,
                               options.similarity_averaging,
                               &similarities,
                               &averaging,
                               &joined)) {
    std::vector<RejectedSimilarity>& rejected =
        community_similarities->rejected_similarities;
    for (auto r = joined.rbegin(); r != joined.rend(); ++r) {
      for (const image_pair_t pair_id : rejected[*r].pairs) {
        community_similarities->false_pairs.erase(pair_id);
      }
      rejected.erase(rejected.begin() + *r);
    }
  }
  summary->community_excluded = averaging.excluded;
  summary->num_estimated_similarities = static_cast<int>(similarities.size());
  summary->num_kept_similarities = 0;
  for (size_t e = 0; e < similarities.size(); ++e) {
    const auto& report = averaging.edges[e];
    summary->num_kept_similarities += report.kept ? 1 : 0;
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: residuals rotation %.3f deg, scale %.4f, "
        "translation %.4f -> %s%s",
        similarities[e].community1,
        similarities[e].community2,
        report.rotation_residual_deg,
        report.log_scale_residual,
        report.relative_translation_residual,
        report.kept           ? "kept"
        : report.contradicted ? "dropped before the averaging (the images "
                                "both models registered contradict it)"
        : report.unconfirmed  ? "dropped (on no cycle, and the images both "
                                "models registered do not confirm it)"
                              : "dropped",
        e + joined.size() >= similarities.size()
            ? " (rejected by the co-visibility check, joins two parts)"
            : "");
  }
  return averaging;
}

// The cross pairs of rejected transforms (community_alignment.h), but those
// of the transforms the merge confirms (Options::confirm_rejected_links).
std::unordered_set<image_pair_t> FalsePairsAfterTheMerge(
    const CommunityMapperController::Options& options,
    const CommunitySimilarities& community_similarities,
    const SimilarityAveragingResult& averaging) {
  const std::vector<RelativeSimilarity>& similarities =
      community_similarities.similarities;
  std::unordered_set<image_pair_t> false_pairs =
      community_similarities.false_pairs;
  if (!options.confirm_rejected_links) {
    return false_pairs;
  }
  for (const RejectedSimilarity& rejected :
       community_similarities.rejected_similarities) {
    const MergeResiduals residuals =
        ResidualsAgainstMerge(rejected, similarities, averaging);
    if (!residuals.joined) {
      continue;  // Not joined through other links: nothing to confirm it.
    }
    const bool confirmed = residuals.WithinBounds(
        options.similarity_averaging, options.rejected_link_max_drift_factor);
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: the similarity the co-visibility check rejected "
        "(%d inliers) against the merge: rotation %.3f deg, scale %.4f, "
        "translation %.4f (links between them: resistance %.2f, bounds times "
        "%.2f) -> %s",
        rejected.similarity.community1,
        rejected.similarity.community2,
        static_cast<int>(rejected.similarity.points1.size()),
        residuals.report.rotation_residual_deg,
        residuals.report.log_scale_residual,
        residuals.report.relative_translation_residual,
        residuals.path_resistance,
        residuals.DriftFactor(options.rejected_link_max_drift_factor),
        confirmed ? StringPrintf("confirmed: its %d image pairs stay in the "
                                 "refinement",
                                 static_cast<int>(rejected.pairs.size()))
                        .c_str()
                  : "still rejected");
    if (confirmed) {
      for (const image_pair_t pair_id : rejected.pairs) {
        false_pairs.erase(pair_id);
      }
    }
  }
  return false_pairs;
}

// Communities that the averaging sent out of the merge lose their model
// here (their images are offered to the merged models); returns those
// whose model is not broken, which keep the images no merged model
// registers (MergeParts). `unconfirmed_communities` receives those of them
// in doubt that left for want of a link their shared images confirm (no
// evidence against their model, unlike links that disagree: such a model
// may be bent), whose models may join as blocks.
std::vector<int> SetAsideExcludedCommunities(
    const std::vector<RelativeSimilarity>& similarities,
    const SimilarityAveragingResult& averaging,
    Models* models_ptr,
    std::vector<int>* unconfirmed_communities,
    CommunityMapperController::Summary* summary) {
  const int num_communities = static_cast<int>(models_ptr->size());
  std::vector<int> set_aside_communities;
  Models& models = *models_ptr;
  for (int c = 0; c < num_communities; ++c) {
    if (averaging.excluded[c]) {
      bool unconfirmed = false;
      for (size_t e = 0; e < similarities.size(); ++e) {
        unconfirmed = unconfirmed || ((similarities[e].community1 == c ||
                                       similarities[e].community2 == c) &&
                                      averaging.edges[e].unconfirmed);
      }
      LOG(WARNING) << StringPrintf(
          "Community %d leaves the merge: %s. Its images are offered to the "
          "merged model.",
          c,
          summary->community_judgements[c].broken ? "its model is broken"
          : summary->community_judgements[c].doubtful
              ? (unconfirmed ? "nothing confirms its similarities and its "
                               "model is in doubt"
                             : "its similarities disagree with the other "
                               "communities' and its model is in doubt")
              : "its similarities disagree with the other communities' "
                "and it is small");
      if (!summary->community_judgements[c].broken) {
        set_aside_communities.push_back(c);
        if (unconfirmed && summary->community_judgements[c].doubtful) {
          unconfirmed_communities->push_back(c);
        }
      }
      models[c].reset();
    }
  }
  return set_aside_communities;
}

// Merges every part of the averaging (communities joined by kept
// similarities) into one model (MergePart), largest parts first as the
// averaging numbers them, each on the images no earlier part's model
// registered plus those offered to it; a part left with fewer than two
// images has no model, and a part of one community with nothing offered is
// its model as it is. Then the set-aside communities keep, as models of
// their own, the images no merged model registered (at least
// Mapper.min_model_size of them). The models are consumed; the seconds
// spent in the refinements are added to `refinement_seconds`.
std::vector<std::shared_ptr<Reconstruction>> MergeParts(
    const CommunityMapperController::Options& options,
    const CommunityImages& communities,
    const std::vector<RelativeSimilarity>& similarities,
    const SimilarityAveragingResult& averaging,
    const PartOffers& offers,
    const std::vector<int>& set_aside_communities,
    const std::unordered_set<image_pair_t>& false_pairs,
    const ViewGraph& view_graph,
    const std::vector<std::string>& model_paths,
    Models* models_ptr,
    double* refinement_seconds) {
  Models& models = *models_ptr;
  const int num_communities = static_cast<int>(models.size());
  // By part: the names of the images offered to it.
  std::map<int, std::unordered_set<std::string>> extra_image_names_of_part;
  for (const auto& part_and_communities : offers.image_communities_of_part) {
    for (const int c : part_and_communities.second) {
      for (const image_t image_id : communities.own_image_ids[c]) {
        extra_image_names_of_part[part_and_communities.first].insert(
            communities.name_of_image.at(image_id));
      }
    }
  }
  // The models written, and the images they registered (which later parts
  // and communities leave out).
  std::vector<std::shared_ptr<Reconstruction>> merged_models;
  std::unordered_set<image_t> registered_image_ids;
  const auto keep_model = [&](std::shared_ptr<Reconstruction> model) {
    registered_image_ids.insert(model->RegImageIds().begin(),
                                model->RegImageIds().end());
    merged_models.push_back(std::move(model));
  };
  // Community c's model restricted to its own images that no earlier
  // model registered: `model` (its copy in memory), or as its stage wrote
  // it if null.
  const auto left_model = [&](const int c,
                              std::shared_ptr<Reconstruction> model) {
    if (!model) {
      model = std::make_shared<Reconstruction>();
      model->Read(model_paths[c]);
    }
    return RestrictToImages(
        ImagesNotTaken(communities.own_image_ids[c], registered_image_ids),
        std::move(model));
  };
  for (int part = 0; part < averaging.NumParts(); ++part) {
    std::vector<int> part_communities;
    size_t num_left_images = 0;
    for (int c = 0; c < num_communities; ++c) {
      if (averaging.part_of_community[c] != part || !models[c]) {
        continue;
      }
      part_communities.push_back(c);
      size_t num_taken = 0;
      for (const image_t image_id : models[c]->RegImageIds()) {
        if (communities.own_image_ids[c].count(image_id) == 0) {
          continue;
        }
        if (registered_image_ids.count(image_id)) {
          ++num_taken;
        } else {
          ++num_left_images;
        }
      }
      if (num_taken > 0) {
        LOG(INFO) << StringPrintf(
            "Community %d: %d of its own images are in an earlier part's "
            "model already",
            c,
            static_cast<int>(num_taken));
      }
    }
    for (const image_t image_id : registered_image_ids) {
      const auto it = communities.name_of_image.find(image_id);
      if (it != communities.name_of_image.end()) {
        extra_image_names_of_part[part].erase(it->second);
      }
    }
    if (part_communities.empty()) {
      continue;
    }
    // (Images offered to it could not register either: there would be no
    // points to register them on.)
    if (num_left_images < 2) {
      LOG(WARNING) << StringPrintf(
          "Part %d: fewer than 2 of its communities' own images are left to "
          "it: no model for it.",
          part);
      for (const int c : part_communities) {
        models[c].reset();
      }
      continue;
    }
    // A part of one community is taken as it is, unless images of other
    // communities are offered to it.
    if (part_communities.size() == 1 &&
        extra_image_names_of_part[part].empty()) {
      const int c = part_communities[0];
      std::shared_ptr<Reconstruction> model = left_model(c, models[c]);
      models[c].reset();
      if (model->NumRegImages() < 2) {
        LOG(WARNING) << StringPrintf(
            "Community %d, alone in its part, registered fewer than 2 of its "
            "own images: no model for it.",
            c);
        continue;
      }
      keep_model(std::move(model));
      continue;
    }
    try {
      // Offered parts come after the part they are offered to: their models
      // are still there. Each keeps only its community's own images: those
      // of its neighbours it registered came through cross-community pairs,
      // which may be the repeated structure whose transform the merge
      // rejected (two identical towers: the model registers its neighbour's
      // images stacked on its own tower, and they agree with the stacking
      // transform). A block then joins only through its own images that the
      // refinement registered one by one.
      // Those of communities that left the merge are read again.
      std::vector<std::shared_ptr<const Reconstruction>> offered_models;
      const auto offered = offers.model_communities_of_part.find(part);
      if (offered != offers.model_communities_of_part.end()) {
        for (const int c : offered->second) {
          offered_models.push_back(left_model(c, models[c]));
        }
      }
      std::shared_ptr<Reconstruction> merged =
          MergePart(options,
                    part_communities,
                    communities,
                    similarities,
                    averaging,
                    extra_image_names_of_part[part],
                    registered_image_ids,
                    false_pairs,
                    view_graph,
                    offered_models,
                    &models,
                    refinement_seconds);
      if (merged->NumRegImages() < 2) {
        LOG(WARNING) << StringPrintf(
            "Part %d: its merged model holds fewer than 2 images: no model "
            "for it.",
            part);
        continue;
      }
      keep_model(std::move(merged));
    } catch (const std::exception& error) {
      // Nothing is lost: the part's communities, as their stage wrote them,
      // become models of their own.
      LOG(ERROR) << "Merging communities failed: " << error.what()
                 << "; each of them is written as a model of its own.";
      for (const int c : part_communities) {
        std::shared_ptr<Reconstruction> model =
            left_model(c, /*model=*/nullptr);
        if (model->NumRegImages() >= 2) {
          keep_model(std::move(model));
        }
      }
    }
  }

  // A community that left the merge keeps the images nobody registered as
  // a model of its own, if there are as many as the incremental mapper
  // keeps in a model (Mapper.min_model_size): it was in doubt or small.
  for (const int c : set_aside_communities) {
    std::shared_ptr<Reconstruction> model = left_model(c, /*model=*/nullptr);
    if (static_cast<int>(model->NumRegImages()) >=
        options.incremental_options.min_model_size) {
      LOG(INFO) << StringPrintf(
          "Community %d left the merge: %d of its images that no merged model "
          "registered keep its model, as a model of its own",
          c,
          static_cast<int>(model->NumRegImages()));
      keep_model(std::move(model));
    }
  }

  return merged_models;
}

}  // namespace

int CommunityMapperController::Options::MinNumMatches() const {
  return min_num_matches > 0 ? min_num_matches
                             : incremental_options.min_num_matches;
}

IncrementalMapperOptions
CommunityMapperController::Options::CommunityIncrementalOptions(
    const std::unordered_set<std::string>& image_names,
    const int num_threads,
    const double own_camera_fraction,
    const bool only_community) const {
  IncrementalMapperOptions community_options = incremental_options;
  community_options.image_names = image_names;
  if (community_options.num_threads < 0) {
    community_options.num_threads = num_threads;
  }
  if (UsesMapperSchedule(own_camera_fraction, only_community)) {
    return community_options;
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

bool CommunityMapperController::Options::UsesMapperSchedule(
    const double own_camera_fraction, const bool only_community) const {
  return only_community ||
         (mapper_schedule_for_own_cameras && own_camera_fraction > 0.5);
}

bool CommunityMapperController::Options::Check() const {
  CHECK_OPTION(community_detection.Check());
  CHECK_OPTION(min_num_matches == -1 || min_num_matches > 0);
  CHECK_OPTION_GE(image_overlap, 0);
  CHECK_OPTION_GE(num_workers, -1);
  CHECK_OPTION_NE(num_workers, 0);
  CHECK_OPTION(community_ba_function_tolerance == -1 ||
               community_ba_function_tolerance >= 0);
  CHECK_OPTION(community_ba_global_ratio == -1 ||
               community_ba_global_ratio > 1);
  CHECK_OPTION(pairwise_similarity.Check());
  CHECK_OPTION(covisibility_check.Check());
  CHECK_OPTION_GE(rejected_link_max_drift_factor, 1.0);
  CHECK_OPTION(similarity_averaging.Check());
  CHECK_OPTION(refinement.Check());
  CHECK_OPTION(pose_graph.Check());
  CHECK_OPTION(incremental_options.Check());
  return true;
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
    LOG(INFO) << workspace_.PlanPath()
              << " exists and fits the database and options: the partition "
                 "is done.";
    return true;
  }
  Timer timer;
  timer.Start();
  const Database database(options_.database_path);
  database_fingerprint_ = DatabaseFingerprint(database);
  const ViewGraph view_graph =
      ViewGraph::Read(database, options_.MinNumMatches(), options_.image_names);
  const ViewGraphEdgeWeight edge_weight = options_.edge_weight;
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
               << options_.MinNumMatches() << " inlier matches"
               << (options_.image_names.empty()
                       ? ""
                       : " between two of the listed images")
               << ": run a matcher first.";
    return false;
  }

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), options_.community_detection);
  summary_.max_modularity = partition.MaxModularity();

  plan_ = CommunityPlan();
  plan_.database_path = options_.database_path;
  plan_.database_fingerprint = database_fingerprint_;
  plan_.options = options_.plan_options;
  plan_.communities.resize(partition.NumCommunities());
  for (size_t vertex = 0; vertex < view_graph.NumVertices(); ++vertex) {
    plan_.communities[partition.membership[vertex]].own_image_names.push_back(
        view_graph.ImageNames()[vertex]);
  }
  const std::vector<std::vector<int>> extended =
      ExtendCommunities(graph, partition, options_.image_overlap);
  for (size_t c = 0; c < extended.size(); ++c) {
    for (const int vertex : extended[c]) {
      if (partition.membership[vertex] != static_cast<int>(c)) {
        plan_.communities[c].borrowed_image_names.push_back(
            view_graph.ImageNames()[vertex]);
      }
    }
  }
  has_plan_ = true;

  std::string sizes;
  summary_.community_sizes.clear();
  for (const auto& community : plan_.communities) {
    summary_.community_sizes.push_back(
        static_cast<int>(community.own_image_names.size()));
    sizes += " " + std::to_string(community.own_image_names.size());
  }
  LOG(INFO) << StringPrintf(
      "%d communities (%d before merging those under %d images), sizes:%s",
      partition.NumCommunities(),
      partition.num_communities_before_merge,
      options_.community_detection.min_community_size,
      sizes.c_str());

  // The plan is written last: it marks a finished partition.
  CreateDirIfNotExists(options_.output_path, /*recursive=*/true);
  WriteTextFileAtomically(
      CommunitiesToText(view_graph,
                        partition,
                        options_.community_detection.modularity_threshold,
                        edge_weight),
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
    database_fingerprint_ = ReadDatabaseFingerprint(options_.database_path);
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
  summary_.community_sizes.clear();
  for (const auto& community : plan_.communities) {
    summary_.community_sizes.push_back(
        static_cast<int>(community.own_image_names.size()));
  }
  has_plan_ = true;
  return true;
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
    double own_camera_fraction = 0;
    if (options_.mapper_schedule_for_own_cameras) {
      try {
        own_camera_fraction = OwnCameraFraction(
            options_.database_path, image_names, database_mutex);
      } catch (const std::exception& error) {
        // E.g. "database is locked" after every retry: the community
        // settings then apply.
        LOG(WARNING) << "Reading the cameras of the images failed: "
                     << error.what();
      }
    }
    const bool only_community = plan_.NumCommunities() == 1;
    if (only_community) {
      LOG(INFO) << "The plan's only community: the mapper's own global "
                   "adjustments (nothing is merged and adjusted after it)";
    } else if (options_.UsesMapperSchedule(own_camera_fraction)) {
      LOG(INFO) << StringPrintf(
          "%.0f%% of the images have a camera of their own: the mapper's "
          "own global adjustments",
          100 * own_camera_fraction);
    }
    const CommunityReconstruction reconstruction = colmap::ReconstructCommunity(
        std::make_shared<const IncrementalMapperOptions>(
            options_.CommunityIncrementalOptions(
                image_names, num_threads, own_camera_fraction, only_community)),
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
    LOG(WARNING) << StringPrintf(
        "Community %d (%d images) could not be reconstructed; it takes no "
        "part in the merge.",
        community_id,
        record.num_images);
  } else {
    LOG(INFO) << StringPrintf(
        "Community %d done: %d of %d images registered%s, %d points (%.1fs)",
        community_id,
        record.num_registered,
        record.num_images,
        record.num_models > 1
            ? StringPrintf(" in the largest of %d models (%d kept beside it)",
                           record.num_models,
                           record.num_other_models)
                  .c_str()
            : "",
        record.num_points,
        record.seconds);
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
  if (!missing.empty()) {
    std::string ids;
    for (const int c : missing) {
      ids += (ids.empty() ? "" : ", ") + std::to_string(c);
    }
    LOG(ERROR) << StringPrintf(
        "%d of the %d communities of the plan have not been reconstructed "
        "(no record in %s): %s. Reconstruct them first (colmap "
        "community_reconstructor --community_id K).",
        static_cast<int>(missing.size()),
        plan_.NumCommunities(),
        workspace_.CommunitiesDir().c_str(),
        ids.c_str());
    return false;
  }

  return true;
}

bool CommunityMapperController::Merge() {
  if (!LoadPlan() || !CheckAllReconstructed()) {
    return false;
  }
  // The merge gives the same model from the same community models, whatever
  // ran them and whichever thread merges.
  SetPRNGSeed(kDefaultPRNGSeed);
  Timer phase_timer;
  phase_timer.Start();
  PrintHeading1("Global similarity averaging");
  // One connection for the view graph and the cross edges' matches.
  const Database database(options_.database_path);
  const ViewGraph view_graph =
      ViewGraph::Read(database, options_.MinNumMatches(), options_.image_names);
  CommunityImages communities = GroupImagesByCommunity(view_graph, plan_);
  summary_.community_of_image = communities.community_of_image;

  // The communities, as their stage left them on disk: the plan's, then the
  // extra ones.
  Models models;
  std::vector<std::string> model_paths;
  ReadCommunityModels(options_,
                      workspace_,
                      plan_.NumCommunities(),
                      &communities,
                      &models,
                      &model_paths,
                      &summary_);

  LogMemory("reading the community models");
  const CrossEdges cross_edges =
      GroupCrossEdges(view_graph, communities.community_of_image);
  summary_.num_community_pairs = static_cast<int>(cross_edges.size());
  CommunitySimilarities community_similarities = EstimateCommunitySimilarities(
      database,
      view_graph,
      cross_edges,
      std::vector<std::shared_ptr<const Reconstruction>>(models.begin(),
                                                         models.end()),
      options_.pairwise_similarity,
      options_.covisibility_check,
      options_.incremental_options.num_threads);
  const SimilarityAveragingResult averaging =
      JudgeAndAverage(options_, &community_similarities, &summary_);
  const std::vector<RelativeSimilarity>& similarities =
      community_similarities.similarities;
  const std::unordered_set<image_pair_t> false_pairs =
      FalsePairsAfterTheMerge(options_, community_similarities, averaging);
  if (!false_pairs.empty()) {
    LOG(INFO) << StringPrintf(
        "%d image pairs between communities support only rejected "
        "transforms: the refinement leaves them out.",
        static_cast<int>(false_pairs.size()));
  }
  // Communities that left the merge but whose models are not broken: the
  // images the merged models do not register keep their community's model,
  // as a model of its own (the incremental mapper too writes the models it
  // could not join). Read again from the workspace at the end.
  std::vector<int> unconfirmed_communities;
  const std::vector<int> set_aside_communities = SetAsideExcludedCommunities(
      similarities, averaging, &models, &unconfirmed_communities, &summary_);
  summary_.phase_seconds.emplace_back("Similarity averaging",
                                      phase_timer.ElapsedSeconds());
  LOG(INFO) << StringPrintf("Similarity averaging: %.3fs (%s)",
                            phase_timer.ElapsedSeconds(),
                            ProcessMemoryToString(ReadProcessMemory()).c_str());

  PrintHeading1("Merging the communities and bundle adjustment");
  phase_timer.Restart();
  std::vector<bool> has_model(models.size());
  for (size_t c = 0; c < models.size(); ++c) {
    has_model[c] = models[c] != nullptr;
  }
  double refinement_seconds = 0.0;
  std::vector<std::shared_ptr<Reconstruction>> merged_models =
      MergeParts(options_,
                 communities,
                 similarities,
                 averaging,
                 PlanPartOffers(averaging.part_of_community,
                                has_model,
                                cross_edges,
                                unconfirmed_communities),
                 set_aside_communities,
                 false_pairs,
                 view_graph,
                 model_paths,
                 &models,
                 &refinement_seconds);

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
  if (!merged_models.empty()) {
    try {
      WriteTextFileAtomically(
          CommunityCamerasToPly(*merged_models[0], summary_.community_of_image),
          workspace_.CommunitiesPlyPath());
    } catch (const std::exception& error) {
      LOG(WARNING) << "Could not write " << workspace_.CommunitiesPlyPath()
                   << ": " << error.what();
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
  LOG(INFO) << StringPrintf("Merge: %.3fs, final bundle adjustment: %.3fs (%s)",
                            merge_total - refinement_seconds,
                            refinement_seconds,
                            ProcessMemoryToString(ReadProcessMemory()).c_str());
  summary_.peak_memory_mb = ReadProcessMemory().peak_resident_mb;
  if (merged_models.empty()) {
    LOG(ERROR) << "No community could be reconstructed: no model written.";
    return false;
  }
  return true;
}

std::string CommunityMapperController::SummaryToText(const Summary& summary) {
  auto join = [](const auto& values) {
    std::string text;
    for (const auto& value : values) {
      text += " " + std::to_string(value);
    }
    return text;
  };
  std::string text =
      "# Figures of a community_mapper run (key value; seconds, MB)\n";
  text +=
      StringPrintf("num_view_graph_images %d\n", summary.num_view_graph_images);
  text += StringPrintf("max_modularity %.4f\n", summary.max_modularity);
  text += StringPrintf("num_communities %d\n",
                       static_cast<int>(summary.community_sizes.size()));
  text += "community_sizes" + join(summary.community_sizes) + "\n";
  text +=
      "extra_community_origins" + join(summary.extra_community_origins) + "\n";
  text += "reconstructed_communities" +
          join(summary.reconstructed_communities) + "\n";
  text += "reused_communities" + join(summary.reused_communities) + "\n";
  int num_excluded = 0;
  for (const bool excluded : summary.community_excluded) {
    num_excluded += excluded ? 1 : 0;
  }
  text += StringPrintf("num_excluded_communities %d\n", num_excluded);
  text += StringPrintf("num_community_pairs %d\n", summary.num_community_pairs);
  text += StringPrintf("num_estimated_similarities %d\n",
                       summary.num_estimated_similarities);
  text +=
      StringPrintf("num_kept_similarities %d\n", summary.num_kept_similarities);
  text += "model_num_registered" + join(summary.model_num_registered) + "\n";
  for (const auto& phase : summary.phase_seconds) {
    std::string name = StringReplace(phase.first, " ", "_");
    std::transform(name.begin(), name.end(), name.begin(), ::tolower);
    text += StringPrintf("phase_seconds %s %.3f\n", name.c_str(), phase.second);
  }
  text += StringPrintf("peak_memory_mb %.1f\n", summary.peak_memory_mb);
  return text;
}

void CommunityMapperController::Run() { RunAllStages(); }

bool CommunityMapperController::RunAllStages() {
  Timer run_timer;
  run_timer.Start();
  summary_ = Summary();
  Timer phase_timer;
  auto end_phase = [&](const std::string& name) {
    summary_.phase_seconds.emplace_back(name, phase_timer.ElapsedSeconds());
    LOG(INFO) << StringPrintf(
        "%s: %.3fs (%s)",
        name.c_str(),
        phase_timer.ElapsedSeconds(),
        ProcessMemoryToString(ReadProcessMemory()).c_str());
  };

  //////////////////////////////////////////////////////////////////////////////
  // 1. View graph and communities (or the plan of an earlier run)
  //////////////////////////////////////////////////////////////////////////////

  PrintHeading1("1. Partitioning the view graph into communities");
  phase_timer.Start();
  if (ExistsFile(workspace_.PlanPath())) {
    LOG(INFO) << "Resuming the run in " << options_.output_path
              << " from its plan";
    if (!LoadPlan()) {
      return false;
    }
  } else if (!Partition()) {
    return false;
  }
  end_phase("Partition");
  if (options_.partition_only) {
    run_timer.PrintMinutes();
    return true;
  }

  //////////////////////////////////////////////////////////////////////////////
  // 2. Community reconstruction
  //////////////////////////////////////////////////////////////////////////////

  PrintHeading1("2. Reconstructing the communities");
  phase_timer.Restart();
  std::vector<int> to_reconstruct;
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    (IsReconstructed(c) ? summary_.reused_communities : to_reconstruct)
        .push_back(c);
  }
  if (!summary_.reused_communities.empty()) {
    std::string ids;
    for (const int c : summary_.reused_communities) {
      ids += " " + std::to_string(c);
    }
    LOG(INFO) << "Reusing the communities reconstructed by an earlier run of "
                 "this plan:"
              << ids;
  }
  const int num_threads = GetEffectiveNumThreads(-1);
  const int num_workers =
      options_.num_workers > 0
          ? options_.num_workers
          : std::max(
                1,
                std::min(static_cast<int>(to_reconstruct.size()), num_threads));
  const int num_threads_per_worker = std::max(1, num_threads / num_workers);
  LOG(INFO) << StringPrintf(
      "Reconstructing %d communities with %d workers, %d threads each",
      static_cast<int>(to_reconstruct.size()),
      num_workers,
      num_threads_per_worker);
  std::mutex database_mutex;
  std::mutex progress_mutex;
  int num_done = 0;
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
      ++num_done;
      LOG(INFO) << StringPrintf(
          "Communities done: %d of %d (%.0fs, %s)",
          num_done + static_cast<int>(summary_.reused_communities.size()),
          plan_.NumCommunities(),
          phase_timer.ElapsedSeconds(),
          ProcessMemoryToString(ReadProcessMemory()).c_str());
    });
  }
  thread_pool.Wait();
  ReleaseFreedMemory();  // The workers' heaps (see process_memory.h).
  end_phase("Communities");
  if (CheckIfStopped()) {
    return false;
  }

  //////////////////////////////////////////////////////////////////////////////
  // 3-4. Similarity averaging, merge and final bundle adjustment
  //////////////////////////////////////////////////////////////////////////////

  const bool merged = Merge();
  LogSummary(summary_);
  run_timer.PrintMinutes();
  return merged;
}

}  // namespace colmap
