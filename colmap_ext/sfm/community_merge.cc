#include "colmap_ext/sfm/community_merge.h"

#include "colmap_ext/graph/view_graph.h"
#include "colmap_ext/scene/filtered_database_cache.h"
#include "colmap_ext/sfm/community_alignment.h"
#include "colmap_ext/sfm/link_confirmation.h"
#include "colmap_ext/sfm/model_join.h"
#include "colmap_ext/sfm/part_offers.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/math/random.h"
#include "colmap/scene/database.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"
#include "colmap/util/types.h"

#include <algorithm>
#include <map>

namespace colmap {
namespace {

using Models = std::vector<std::shared_ptr<Reconstruction>>;

// Where the memory stands after a step (for a long run's log).
void LogMemory(const std::string& step) {
  LOG(INFO) << "Memory after " << step << ": "
            << ProcessMemoryToString(ReadProcessMemory());
}

// The own images of every community, by the plan.
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
// model. Its report and origin are added to `result`.
void AddExtraCommunities(const CommunityWorkspace& workspace,
                         const CommunityRecord& record,
                         const int min_model_size,
                         CommunityImages* communities,
                         Models* models,
                         std::vector<std::string>* model_paths,
                         CommunityMergeResult* result) {
  const int c = record.community_id;
  const std::vector<image_t> reg_image_ids = (*models)[c]->RegImageIds();
  std::unordered_set<image_t> taken_image_ids(reg_image_ids.begin(),
                                              reg_image_ids.end());
  for (int index = 1; index <= record.num_other_models; ++index) {
    auto other_model = std::make_shared<Reconstruction>();
    const std::string path = workspace.CommunityOtherModelPath(c, index);
    other_model->Read(path);
    const std::vector<image_t> other_reg_image_ids = other_model->RegImageIds();
    std::unordered_set<image_t> owned_image_ids;
    for (const image_t image_id : other_reg_image_ids) {
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
    taken_image_ids.insert(other_reg_image_ids.begin(),
                           other_reg_image_ids.end());
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
    CommunityModelReport report = result->community_reports[c];
    report.num_registered = static_cast<int>(other_model->NumRegImages());
    report.model_index = index + 1;
    result->community_reports.push_back(report);
    result->extra_community_origins.push_back(c);
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

}  // namespace

bool CommunityMergeOptions::Check() const {
  CHECK_OPTION_GT(min_num_matches, 0);
  CHECK_OPTION(pairwise_similarity.Check());
  CHECK_OPTION(covisibility_check.Check());
  CHECK_OPTION_GE(rejected_link_max_drift_factor, 1.0);
  CHECK_OPTION(similarity_averaging.Check());
  CHECK_OPTION(refinement.Check());
  CHECK_OPTION(incremental_options.Check());
  return true;
}

CommunityMerge::CommunityMerge(const CommunityMergeOptions& options,
                               const CommunityPlan& plan,
                               const CommunityWorkspace& workspace)
    : options_(options), plan_(plan), workspace_(workspace) {
  THROW_CHECK(options_.Check());
}

void CommunityMerge::EstimateSimilarities() {
  THROW_CHECK_EQ(num_phases_done_, 0) << "the merge's phases run once each";
  // The merge gives the same model from the same community models, whatever
  // ran them and whichever thread merges.
  SetPRNGSeed(kDefaultPRNGSeed);

  // One connection for the view graph and the cross edges' matches.
  const std::shared_ptr<Database> database =
      Database::Open(options_.database_path);
  view_graph_ = std::make_unique<ViewGraph>(ViewGraph::Read(
      *database, options_.min_num_matches, options_.image_names));
  result_.num_view_graph_images = static_cast<int>(view_graph_->NumVertices());
  result_.num_view_graph_edges = static_cast<int>(view_graph_->NumEdges());
  communities_ = GroupImagesByCommunity(*view_graph_, plan_);
  result_.community_of_image = communities_.community_of_image;

  // The communities, as their stage left them on disk: the plan's, then the
  // extra ones.
  ReadCommunityModels();
  LogMemory("reading the community models");

  cross_edges_ = GroupCrossEdges(*view_graph_, communities_.community_of_image);
  result_.num_community_pairs = static_cast<int>(cross_edges_.size());
  similarities_ = EstimateCommunitySimilarities(
      *database,
      *view_graph_,
      cross_edges_,
      std::vector<std::shared_ptr<const Reconstruction>>(models_.begin(),
                                                         models_.end()),
      options_.pairwise_similarity,
      options_.covisibility_check,
      options_.incremental_options.num_threads);
  result_.num_estimated_similarities =
      static_cast<int>(similarities_.similarities.size());
  num_phases_done_ = 1;
}

// The communities' models as their stage left them in the workspace (none
// for a community that registered nothing), the plan's first, then, with
// `merge_other_models`, the extra communities (AddExtraCommunities), with
// their paths and reports.
void CommunityMerge::ReadCommunityModels() {
  const int num_plan_communities = plan_.NumCommunities();
  models_.assign(num_plan_communities, nullptr);
  model_paths_.clear();
  std::vector<CommunityRecord> records;
  result_.community_reports.assign(num_plan_communities,
                                   CommunityModelReport());
  for (int c = 0; c < num_plan_communities; ++c) {
    records.push_back(CommunityRecordFromText(
        ReadTextFile(workspace_.CommunityRecordPath(c))));
    const CommunityRecord& record = records.back();
    CommunityModelReport& report = result_.community_reports[c];
    report.num_registered = record.num_registered;
    report.num_models = record.num_models;
    model_paths_.push_back(workspace_.CommunityModelPath(c));
    if (record.num_registered > 0) {
      models_[c] = std::make_shared<Reconstruction>();
      models_[c]->Read(model_paths_.back());
    }
  }
  result_.extra_community_origins.clear();
  for (int c = 0; c < num_plan_communities; ++c) {
    if (models_[c] && options_.merge_other_models) {
      AddExtraCommunities(workspace_,
                          records[c],
                          options_.incremental_options.min_model_size,
                          &communities_,
                          &models_,
                          &model_paths_,
                          &result_);
    }
  }
}

void CommunityMerge::AverageSimilarities() {
  THROW_CHECK_EQ(num_phases_done_, 1) << "EstimateSimilarities() first";
  const int num_communities = static_cast<int>(models_.size());
  std::vector<AveragedCommunity> averaged_communities(num_communities);
  for (int c = 0; c < num_communities; ++c) {
    averaged_communities[c].num_images =
        result_.community_reports[c].num_registered;
  }
  const std::vector<RelativeSimilarity>& similarities =
      similarities_.similarities;
  averaging_ = colmap::AverageSimilarities(
      averaged_communities, similarities, options_.similarity_averaging);
  result_.community_excluded = averaging_.excluded;
  result_.num_kept_similarities = 0;
  for (size_t e = 0; e < similarities.size(); ++e) {
    const auto& report = averaging_.edges[e];
    result_.num_kept_similarities += report.kept ? 1 : 0;
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: displacement %.4f (rotation %.3f deg, scale "
        "%.4f) -> %s",
        similarities[e].community1,
        similarities[e].community2,
        report.relative_displacement,
        report.rotation_residual_deg,
        report.log_scale_residual,
        report.kept           ? "kept"
        : report.contradicted ? "dropped before the averaging (the images "
                                "both models registered contradict it)"
        : report.community_left
            ? "dropped (one of its communities left the merge)"
        : report.unconfirmed
            ? "dropped (on no cycle, and the images both "
              "models registered do not confirm it)"
            : "dropped (the displacement of the averaging that dropped it, "
              "with it in)");
  }

  false_pairs_ =
      options_.confirm_rejected_links
          ? ConfirmRejectedLinks(
                similarities_,
                averaging_,
                options_.similarity_averaging.max_relative_displacement,
                options_.rejected_link_max_drift_factor)
          : similarities_.false_pairs;
  if (!false_pairs_.empty()) {
    LOG(INFO) << StringPrintf(
        "%d image pairs between communities support only rejected "
        "transforms: the refinement leaves them out.",
        static_cast<int>(false_pairs_.size()));
  }
  SetAsideExcludedCommunities();
  num_phases_done_ = 2;
}

// Communities that the averaging sent out of the merge lose their model
// here and are set aside: their images are offered to the merged models,
// their models too, as blocks where they fit (block_registration.h), and
// they keep the images no merged model registers (MergeParts).
void CommunityMerge::SetAsideExcludedCommunities() {
  for (int c = 0; c < static_cast<int>(models_.size()); ++c) {
    if (!averaging_.excluded[c]) {
      continue;
    }
    LOG(WARNING) << StringPrintf(
        "Community %d leaves the merge: its similarities disagree with the "
        "other communities' and it is small. Its images and its model are "
        "offered to the merged model.",
        c);
    set_aside_communities_.push_back(c);
    models_[c].reset();
  }
}

std::shared_ptr<Reconstruction> CommunityMerge::LeftModel(
    const int c,
    std::shared_ptr<Reconstruction> model,
    const std::unordered_set<image_t>& taken_image_ids) const {
  if (!model) {
    model = std::make_shared<Reconstruction>();
    model->Read(model_paths_[c]);
  }
  return RestrictToImages(
      ImagesNotTaken(communities_.own_image_ids[c], taken_image_ids),
      std::move(model));
}

void CommunityMerge::KeepModel(
    std::shared_ptr<Reconstruction> model,
    std::unordered_set<image_t>* registered_image_ids) {
  const std::vector<image_t> reg_image_ids = model->RegImageIds();
  registered_image_ids->insert(reg_image_ids.begin(), reg_image_ids.end());
  result_.models.push_back(std::move(model));
}

std::vector<int> CommunityMerge::PartCommunities(
    const int part,
    const std::unordered_set<image_t>& registered_image_ids,
    size_t* num_left_images) const {
  std::vector<int> part_communities;
  *num_left_images = 0;
  for (int c = 0; c < static_cast<int>(models_.size()); ++c) {
    if (averaging_.part_of_community[c] != part || !models_[c]) {
      continue;
    }
    part_communities.push_back(c);
    size_t num_taken = 0;
    for (const image_t image_id : models_[c]->RegImageIds()) {
      if (communities_.own_image_ids[c].count(image_id) == 0) {
        continue;
      }
      if (registered_image_ids.count(image_id)) {
        ++num_taken;
      } else {
        ++*num_left_images;
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
  return part_communities;
}

void CommunityMerge::KeepSetAsideCommunities(
    std::unordered_set<image_t>* registered_image_ids) {
  // A community that left the merge keeps the images nobody registered as
  // a model of its own, if there are as many as the incremental mapper
  // keeps in a model (Mapper.min_model_size): it was small.
  for (const int c : set_aside_communities_) {
    std::shared_ptr<Reconstruction> model =
        LeftModel(c, /*model=*/nullptr, *registered_image_ids);
    if (static_cast<int>(model->NumRegImages()) >=
        options_.incremental_options.min_model_size) {
      LOG(INFO) << StringPrintf(
          "Community %d left the merge: %d of its images that no merged model "
          "registered keep its model, as a model of its own",
          c,
          static_cast<int>(model->NumRegImages()));
      KeepModel(std::move(model), registered_image_ids);
    }
  }
}

// Every part of the averaging is merged into one model (MergePart),
// largest parts first as the averaging numbers them, each on the images no
// earlier part's model registered plus those offered to it; a part left
// with fewer than two images has no model, and a part of one community
// with nothing offered is its model as it is. Then the set-aside
// communities keep, as models of their own, the images no merged model
// registered (at least Mapper.min_model_size of them). The communities'
// models are consumed.
void CommunityMerge::MergeParts() {
  THROW_CHECK_EQ(num_phases_done_, 2) << "AverageSimilarities() first";
  const int num_communities = static_cast<int>(models_.size());
  std::vector<bool> has_model(num_communities);
  for (int c = 0; c < num_communities; ++c) {
    has_model[c] = models_[c] != nullptr;
  }
  const PartOffers offers = PlanPartOffers(averaging_.part_of_community,
                                           has_model,
                                           cross_edges_,
                                           set_aside_communities_);
  // By part: the names of the images offered to it.
  std::map<int, std::unordered_set<std::string>> extra_image_names_of_part;
  for (const auto& part_and_communities : offers.image_communities_of_part) {
    for (const int c : part_and_communities.second) {
      for (const image_t image_id : communities_.own_image_ids[c]) {
        extra_image_names_of_part[part_and_communities.first].insert(
            communities_.name_of_image.at(image_id));
      }
    }
  }
  // The images the models written registered (which later parts and
  // communities leave out).
  std::unordered_set<image_t> registered_image_ids;
  for (int part = 0; part < averaging_.NumParts(); ++part) {
    size_t num_left_images = 0;
    const std::vector<int> part_communities =
        PartCommunities(part, registered_image_ids, &num_left_images);
    for (const image_t image_id : registered_image_ids) {
      const auto it = communities_.name_of_image.find(image_id);
      if (it != communities_.name_of_image.end()) {
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
        models_[c].reset();
      }
      continue;
    }
    // A part of one community is taken as it is, unless images of other
    // communities are offered to it.
    if (part_communities.size() == 1 &&
        extra_image_names_of_part[part].empty()) {
      const int c = part_communities[0];
      std::shared_ptr<Reconstruction> model =
          LeftModel(c, models_[c], registered_image_ids);
      models_[c].reset();
      if (model->NumRegImages() < 2) {
        LOG(WARNING) << StringPrintf(
            "Community %d, alone in its part, registered fewer than 2 of its "
            "own images: no model for it.",
            c);
        continue;
      }
      KeepModel(std::move(model), &registered_image_ids);
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
          offered_models.push_back(
              LeftModel(c, models_[c], registered_image_ids));
        }
      }
      std::shared_ptr<Reconstruction> merged =
          MergePart(part_communities,
                    extra_image_names_of_part[part],
                    registered_image_ids,
                    offered_models);
      if (merged->NumRegImages() < 2) {
        LOG(WARNING) << StringPrintf(
            "Part %d: its merged model holds fewer than 2 images: no model "
            "for it.",
            part);
        continue;
      }
      KeepModel(std::move(merged), &registered_image_ids);
    } catch (const std::exception& error) {
      // Nothing is lost: the part's communities, as their stage wrote them,
      // become models of their own.
      LOG(ERROR) << "Merging communities failed: " << error.what()
                 << "; each of them is written as a model of its own.";
      for (const int c : part_communities) {
        std::shared_ptr<Reconstruction> model =
            LeftModel(c, /*model=*/nullptr, registered_image_ids);
        if (model->NumRegImages() >= 2) {
          KeepModel(std::move(model), &registered_image_ids);
        }
      }
    }
  }

  KeepSetAsideCommunities(&registered_image_ids);
  std::stable_sort(result_.models.begin(),
                   result_.models.end(),
                   [](const std::shared_ptr<Reconstruction>& a,
                      const std::shared_ptr<Reconstruction>& b) {
                     return a->NumRegImages() > b->NumRegImages();
                   });
  num_phases_done_ = 3;
}

// An image left without any pair (all contradicting the merge) cannot be
// refined: it stays out. (The view graph tells, before the models are
// joined and released, which images the correspondences will hold.)
void CommunityMerge::LeaveOutUnpairedImages(
    const std::unordered_set<std::string>& part_image_names,
    std::vector<std::unordered_set<image_t>>* owned_image_ids) const {
  std::unordered_set<image_t> connected_image_ids;
  for (const ViewGraph::Edge& edge : view_graph_->Edges()) {
    const image_t image_id1 = view_graph_->ImageIds()[edge.vertex1];
    const image_t image_id2 = view_graph_->ImageIds()[edge.vertex2];
    if (part_image_names.count(view_graph_->ImageNames()[edge.vertex1]) &&
        part_image_names.count(view_graph_->ImageNames()[edge.vertex2]) &&
        !false_pairs_.count(ImagePairToPairId(image_id1, image_id2))) {
      connected_image_ids.insert(image_id1);
      connected_image_ids.insert(image_id2);
    }
  }
  for (std::unordered_set<image_t>& image_ids : *owned_image_ids) {
    for (auto it = image_ids.begin(); it != image_ids.end();) {
      if (connected_image_ids.count(*it)) {
        ++it;
      } else {
        LOG(WARNING) << "Image " << communities_.name_of_image.at(*it)
                     << " has no image pair left in the merged model; it is "
                        "left out.";
        it = image_ids.erase(it);
      }
    }
  }
}

// The pairs of joined points (merged ids) that the kept similarities of
// the part found to correspond, `point3D_ids` mapping each community's
// point ids (by its index in the part) to the merged model's.
std::vector<std::pair<point3D_t, point3D_t>>
CommunityMerge::PartCorrespondingPoints(
    const std::vector<int>& part_communities,
    const std::map<int, size_t>& index_in_part,
    const std::vector<std::unordered_map<point3D_t, point3D_t>>& point3D_ids)
    const {
  std::vector<std::pair<point3D_t, point3D_t>> corresponding_points;
  for (size_t e = 0; e < similarities_.similarities.size(); ++e) {
    if (!averaging_.edges[e].kept ||
        averaging_
                .part_of_community[similarities_.similarities[e].community1] !=
            averaging_.part_of_community[part_communities[0]]) {
      continue;
    }
    const auto& ids1 =
        point3D_ids[index_in_part.at(similarities_.similarities[e].community1)];
    const auto& ids2 =
        point3D_ids[index_in_part.at(similarities_.similarities[e].community2)];
    for (const auto& pair : similarities_.similarities[e].point3D_ids) {
      const auto it1 = ids1.find(pair.first);
      const auto it2 = ids2.find(pair.second);
      if (it1 != ids1.end() && it2 != ids2.end()) {
        corresponding_points.emplace_back(it1->second, it2->second);
      }
    }
  }
  return corresponding_points;
}

// The correspondences of the part's images, without the false pairs, once
// the communities' models are released and the joined cameras aligned
// (MergedModelRefiner); every image registered in `merged` must have some.
std::shared_ptr<const DatabaseCache> CommunityMerge::LoadPartCorrespondences(
    const std::unordered_set<std::string>& part_image_names,
    const Reconstruction& merged) const {
  DatabaseCache::Options database_cache_options;
  database_cache_options.min_num_matches =
      static_cast<size_t>(options_.min_num_matches);
  database_cache_options.ignore_watermarks =
      options_.incremental_options.ignore_watermarks;
  database_cache_options.image_names = part_image_names;
  std::shared_ptr<DatabaseCache> database_cache;
  {
    const std::shared_ptr<Database> database =
        Database::Open(options_.database_path);
    database_cache = CreateFilteredDatabaseCache(
        *database,
        database_cache_options,
        [this](const image_t image_id1, const image_t image_id2) {
          return false_pairs_.count(ImagePairToPairId(image_id1, image_id2)) ==
                 0;
        });
  }
  // Building the correspondence graph grows a vector per keypoint and
  // then flattens them; the freed vectors would stay resident through the
  // refinement (see ReleaseFreedMemory).
  ReleaseFreedMemory();
  for (const image_t image_id : merged.RegImageIds()) {
    THROW_CHECK(database_cache->ExistsImage(image_id))
        << "image " << merged.Image(image_id).Name()
        << " has no correspondences";
  }
  LogMemory("loading the correspondences");
  return std::shared_ptr<const DatabaseCache>(std::move(database_cache));
}

// Joins the communities of one part (connected by kept similarities) into
// one model in the global frame, merges their corresponding points and
// refines the result on the part's own images plus `extra_image_names`
// (images of communities without a model or that left the merge, and of
// parts offered to this one, which the refinement tries to register). Own
// images in `taken_image_ids` (registered by an earlier part's model) are
// left out. `offered_models` are the models (their own images only) of the
// communities of parts offered to this one and of those offered to it
// that left the merge, which the refinement registers as blocks where it
// can. The communities' own models are consumed. Adds the seconds spent in
// the refinement to the result's.
std::shared_ptr<Reconstruction> CommunityMerge::MergePart(
    const std::vector<int>& part_communities,
    const std::unordered_set<std::string>& extra_image_names,
    const std::unordered_set<image_t>& taken_image_ids,
    const std::vector<std::shared_ptr<const Reconstruction>>& offered_models) {
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
    for (const image_t image_id : communities_.own_image_ids[c]) {
      community_of_image.emplace(image_id, c);
    }
    index_in_part.emplace(c, part_models.size());
    part_models.push_back(models_[c].get());
    world_from_community.push_back(averaging_.world_from_community[c]);
    owned_image_ids.push_back(
        ImagesNotTaken(communities_.own_image_ids[c], taken_image_ids));
    for (const image_t image_id : owned_image_ids.back()) {
      part_image_names.insert(communities_.name_of_image.at(image_id));
    }
  }
  LeaveOutUnpairedImages(part_image_names, &owned_image_ids);
  auto merged = std::make_shared<Reconstruction>();
  std::vector<std::unordered_map<point3D_t, point3D_t>> point3D_ids;
  JoinReconstructions(part_models,
                      world_from_community,
                      owned_image_ids,
                      merged.get(),
                      &point3D_ids);
  for (const int c : part_communities) {
    models_[c].reset();  // Joined: the community's copy is not needed.
  }
  ReleaseFreedMemory();

  const std::vector<std::pair<point3D_t, point3D_t>> corresponding_points =
      PartCorrespondingPoints(part_communities, index_in_part, point3D_ids);
  const size_t num_merged_points =
      MergeCorrespondingPoints(corresponding_points, merged.get());
  LOG(INFO) << StringPrintf(
      "Joined %d images and %d points; merged %d corresponding points",
      static_cast<int>(merged->NumRegImages()),
      static_cast<int>(merged->NumPoints3D()),
      static_cast<int>(num_merged_points));
  LogMemory("joining the models");

  // The correspondences, once the communities' models are released and
  // the joined cameras aligned (MergedModelRefiner).
  const auto load_correspondences = [&]() {
    return LoadPartCorrespondences(part_image_names, *merged);
  };

  Timer timer;
  timer.Start();
  const MergedModelRefinementSummary refinement =
      MergedModelRefiner(options_.refinement,
                         options_.incremental_options,
                         load_correspondences,
                         community_of_image,
                         offered_models,
                         merged)
          .Run();
  result_.refinement_seconds += timer.ElapsedSeconds();
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
  if (options_.incremental_options.extract_colors) {
    merged->ExtractColorsForAllImages(options_.image_path,
                                      options_.incremental_options.num_threads);
  }
  return merged;
}

CommunityMergeResult MergeCommunities(const CommunityMergeOptions& options,
                                      const CommunityPlan& plan,
                                      const CommunityWorkspace& workspace) {
  CommunityMerge merge(options, plan, workspace);
  merge.EstimateSimilarities();
  merge.AverageSimilarities();
  merge.MergeParts();
  return merge.Result();
}

}  // namespace colmap
