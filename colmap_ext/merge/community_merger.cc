#include "colmap_ext/merge/community_merger.h"

#include "colmap_ext/merge/global_refinement.h"
#include "colmap_ext/merge/model_join.h"
#include "colmap_ext/merge/part_offers.h"
#include "colmap_ext/reconstruction/filtered_database_cache.h"
#include "colmap_ext/util/process_memory.h"

#include "colmap/math/random.h"
#include "colmap/scene/database.h"
#include "colmap/sfm/observation_manager.h"
#include "colmap/util/logging.h"
#include "colmap/util/misc.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"
#include "colmap/util/types.h"

#include <algorithm>
#include <set>

namespace colmap {

bool CommunityMergerOptions::Check() const {
  CHECK_OPTION_GT(min_num_matches, 0);
  CHECK_OPTION_GE(refinement_function_tolerance, 0);
  CHECK_OPTION(pairwise_similarity.Check());
  CHECK_OPTION(covisibility_check.Check());
  CHECK_OPTION(similarity_averaging.Check());
  CHECK_OPTION(incremental_options.Check());
  return true;
}

CommunityMerger::CommunityMerger(const CommunityMergerOptions& options,
                                 const CommunityPlan& plan,
                                 const CommunityWorkspace& workspace)
    : options_(options), plan_(plan), workspace_(workspace) {
  THROW_CHECK(options_.Check());
}

void CommunityMerger::EstimateSimilarities() {
  // One connection for the view graph and the cross edges' matches.
  const std::shared_ptr<Database> database =
      Database::Open(options_.database_path);
  view_graph_ = std::make_unique<ViewGraph>(ViewGraph::Read(
      *database, options_.min_num_matches, options_.image_names));
  result_.num_view_graph_images = static_cast<int>(view_graph_->NumVertices());
  result_.num_view_graph_edges = static_cast<int>(view_graph_->NumEdges());
  // The own images of every community, by the plan.
  std::unordered_map<std::string, image_t> image_of_name;
  for (size_t vertex = 0; vertex < view_graph_->NumVertices(); ++vertex) {
    image_of_name.emplace(view_graph_->ImageNames()[vertex],
                          view_graph_->ImageIds()[vertex]);
  }
  communities_.own_image_ids.resize(plan_.NumCommunities());
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    for (const std::string& name : plan_.communities[c].own_image_names) {
      const image_t image_id = image_of_name.at(name);
      communities_.own_image_ids[c].insert(image_id);
      communities_.name_of_image.emplace(image_id, name);
      communities_.community_of_image.emplace(image_id, c);
    }
  }
  result_.community_of_image = communities_.community_of_image;

  ReadCommunityModels();

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
  LOG_IF(INFO, !similarities_.false_pairs.empty()) << StringPrintf(
      "%d image pairs between communities support only rejected "
      "transforms: the merged models leave them out.",
      static_cast<int>(similarities_.false_pairs.size()));
}

// The communities' models as their stage wrote them (none where nothing was
// registered), the plan's then the extra ones, with paths and reports.
void CommunityMerger::ReadCommunityModels() {
  const int num_plan_communities = plan_.NumCommunities();
  models_.assign(num_plan_communities, nullptr);
  std::vector<CommunityRecord> records;
  for (int c = 0; c < num_plan_communities; ++c) {
    records.push_back(CommunityRecordFromText(
        ReadTextFile(workspace_.CommunityRecordPath(c))));
    const CommunityRecord& record = records.back();
    result_.community_reports.push_back(
        {record.num_registered, record.num_models});
    model_paths_.push_back(workspace_.CommunityModelPath(c));
    if (record.num_registered > 0) {
      models_[c] = std::make_shared<Reconstruction>();
      models_[c]->Read(model_paths_.back());
    }
  }
  for (int c = 0; c < num_plan_communities; ++c) {
    if (models_[c]) {
      AddExtraCommunities(records[c]);
    }
  }
}

// Community `record.community_id`'s other models (largest first) each become
// an extra community, numbered after those in `models_`, if they registered
// at least --Mapper.min_model_size of its own images that no larger model of
// it taking part did; it owns those images. Its report and origin are added.
void CommunityMerger::AddExtraCommunities(const CommunityRecord& record) {
  const int c = record.community_id;
  const std::vector<image_t> reg_image_ids = models_[c]->RegImageIds();
  std::unordered_set<image_t> taken_image_ids(reg_image_ids.begin(),
                                              reg_image_ids.end());
  for (int index = 1; index <= record.num_other_models; ++index) {
    auto other_model = std::make_shared<Reconstruction>();
    const std::string path = workspace_.CommunityOtherModelPath(c, index);
    other_model->Read(path);
    const std::vector<image_t> other_reg_image_ids = other_model->RegImageIds();
    std::unordered_set<image_t> owned_image_ids;
    for (const image_t image_id : other_reg_image_ids) {
      if (communities_.own_image_ids[c].count(image_id) > 0 &&
          taken_image_ids.count(image_id) == 0) {
        owned_image_ids.insert(image_id);
      }
    }
    const bool takes_part = static_cast<int>(owned_image_ids.size()) >=
                            options_.incremental_options.min_model_size;
    const int extra = static_cast<int>(models_.size());
    LOG(INFO) << "Community " << c << "'s model " << index + 1 << " of "
              << record.num_models << " holds " << owned_image_ids.size()
              << " of its own images that no larger model of it holds: "
              << (takes_part
                      ? "it takes part as community " + std::to_string(extra)
                      : std::string("too few to take part"));
    if (!takes_part) {
      continue;
    }
    taken_image_ids.insert(other_reg_image_ids.begin(),
                           other_reg_image_ids.end());
    for (const image_t image_id : owned_image_ids) {
      communities_.own_image_ids[c].erase(image_id);
      communities_.community_of_image[image_id] = extra;
    }
    communities_.own_image_ids.push_back(std::move(owned_image_ids));
    CommunityModelReport report = result_.community_reports[c];
    report.num_registered = static_cast<int>(other_model->NumRegImages());
    report.model_index = index + 1;
    result_.community_reports.push_back(report);
    result_.extra_community_origins.push_back(c);
    models_.push_back(std::move(other_model));
    model_paths_.push_back(path);
  }
}

void CommunityMerger::AverageSimilarities() {
  std::vector<AveragedCommunity> averaged_communities;
  for (const CommunityModelReport& report : result_.community_reports) {
    averaged_communities.push_back({report.num_registered});
  }
  const std::vector<RelativeSimilarity>& similarities =
      similarities_.similarities;
  averaging_ = colmap::AverageSimilarities(
      averaged_communities, similarities, options_.similarity_averaging);
  for (size_t e = 0; e < similarities.size(); ++e) {
    const auto& report = averaging_.edges[e];
    result_.num_kept_similarities += report.kept ? 1 : 0;
    LOG(INFO) << StringPrintf(
        "Communities %d-%d: displacement %.4f -> %s",
        similarities[e].community1,
        similarities[e].community2,
        report.relative_displacement,
        report.kept ? "kept"
        : report.contradicted
            ? "dropped (the images both models registered contradict it)"
        : report.unconfirmed
            ? "dropped (on no cycle, and the images both "
              "models registered do not confirm it)"
            : "dropped (the displacement of the averaging that dropped it, "
              "with it in)");
  }
}

std::shared_ptr<Reconstruction> CommunityMerger::OwnModel(
    const int c, std::shared_ptr<Reconstruction> model) const {
  if (!model) {
    model = std::make_shared<Reconstruction>();
    model->Read(model_paths_[c]);
  }
  return RestrictToImages(communities_.own_image_ids[c], std::move(model));
}

void CommunityMerger::Solve() {
  THROW_CHECK(!solved_) << "Solve() runs once";
  solved_ = true;
  // The merge gives the same model from the same community models, whatever
  // ran them and whichever thread merges.
  SetPRNGSeed(kDefaultPRNGSeed);
  Timer timer;
  const auto end_stage = [&](const std::string& name) {
    result_.stage_seconds.emplace_back(name, timer.ElapsedSeconds());
    LOG(INFO) << StringPrintf(
        "%s done in %.3f seconds (%s)",
        name.c_str(),
        timer.ElapsedSeconds(),
        ProcessMemoryToString(ReadProcessMemory()).c_str());
  };

  LOG_HEADING1("Merge 1/4: pairwise similarities between communities");
  timer.Start();
  EstimateSimilarities();
  end_stage("Pairwise similarities");

  LOG_HEADING1("Merge 2/4: similarity averaging");
  timer.Restart();
  AverageSimilarities();
  end_stage("Similarity averaging");

  LOG_HEADING1("Merge 3/4: global refinement of every part");
  timer.Restart();
  JoinAndRefineParts();
  end_stage("Global refinement");

  LOG_HEADING1("Merge 4/4: registration of the remaining images");
  timer.Restart();
  RegisterRemainingImagesOfParts();
  end_stage("Registration");
}

// Every part of the averaging, largest first as the averaging numbers
// them, becomes one model: a part of one community its model (its own
// images), a part of several the communities joined in the averaged frame
// and refined over all their images. Where the join or its refinement
// fails, nothing is lost: the part's communities become models of their
// own. The communities' models are consumed (released once joined, so that
// the refinement holds only the joined model).
void CommunityMerger::JoinAndRefineParts() {
  const int num_communities = static_cast<int>(models_.size());
  std::vector<bool> has_model(num_communities);
  for (int c = 0; c < num_communities; ++c) {
    has_model[c] = models_[c] != nullptr;
  }
  const PartOffers offers =
      PlanPartOffers(averaging_.part_of_community, has_model, cross_edges_);
  for (int part = 0; part < averaging_.NumParts(); ++part) {
    std::vector<int> part_communities;
    for (int c = 0; c < num_communities; ++c) {
      if (models_[c] && averaging_.part_of_community[c] == part) {
        part_communities.push_back(c);
      }
    }
    if (part_communities.empty()) {
      continue;
    }
    PartModel part_model{/*model=*/nullptr, part_communities};
    const auto offered = offers.image_communities_of_part.find(part);
    if (offered != offers.image_communities_of_part.end()) {
      part_model.offered_communities = offered->second;
    }
    if (part_communities.size() == 1) {
      const int c = part_communities[0];
      part_model.model = OwnModel(c, std::move(models_[c]));
      part_models_.push_back(std::move(part_model));
      continue;
    }
    try {
      part_model.model = JoinPart(part_communities);
      part_model.joined = true;
      // The joined model holds all the refinement needs.
      for (const int c : part_communities) {
        models_[c].reset();
      }
      ReleaseFreedMemory();
      if (!options_.skip_global_refinement) {
        RefinePart(part_model.model);
        // The refinement's correspondences and adjustment are freed.
        ReleaseFreedMemory();
      }
      part_models_.push_back(std::move(part_model));
    } catch (const std::exception& error) {
      LOG(ERROR) << "Merging communities failed: " << error.what()
                 << "; each of them is written as a model of its own.";
      for (const int c : part_communities) {
        models_[c].reset();
        part_models_.push_back(
            {OwnModel(c, /*model=*/nullptr), /*communities=*/{c}});
      }
      ReleaseFreedMemory();
    }
  }
}

void CommunityMerger::RefinePart(
    const std::shared_ptr<Reconstruction>& merged) const {
  const double initial_error = merged->ComputeMeanReprojectionError();
  IncrementalPipelineOptions refinement_options = options_.incremental_options;
  refinement_options.ba_global_function_tolerance =
      options_.refinement_function_tolerance;
  THROW_CHECK(
      RefineMergedModel(refinement_options,
                        LoadPartCorrespondences(/*image_names=*/{}, *merged),
                        merged))
      << "the bundle adjustment of the merged model failed";
  merged->TearDown();
  merged->UpdatePoint3DErrors();
  LOG(INFO) << StringPrintf(
      "Refined model: %d images, %d points, mean reprojection error %.3f px "
      "(%.3f px joined)",
      static_cast<int>(merged->NumRegImages()),
      static_cast<int>(merged->NumPoints3D()),
      merged->ComputeMeanReprojectionError(),
      initial_error);
}

// Largest part first, each model loses the images an earlier one holds,
// then registers the images of its communities that it does not hold and
// those offered to it (part_offers.h), and is kept where it holds at least
// two images. A part of one community is registered into only where images
// are offered to it: its community's mapper tried its own images already.
void CommunityMerger::RegisterRemainingImagesOfParts() {
  std::unordered_set<image_t> registered_image_ids;
  for (PartModel& part_model : part_models_) {
    // A part whose images the registration took in part into one earlier
    // model joins it on the images both hold, as hierarchical_mapper merges
    // its clusters (COLMAP's MergeAndFilterReconstructions, its 8 px). Not
    // where two took some: the other's would then be in two models.
    std::set<Reconstruction*> holders;
    for (const image_t image_id : part_model.model->RegImageIds()) {
      for (const auto& model : result_.models) {
        if (HasPosedImage(*model, image_id)) {
          holders.insert(model.get());
        }
      }
    }
    Reconstruction* holder = holders.size() == 1 ? *holders.begin() : nullptr;
    if (holder &&
        MergeAndFilterReconstructions(8.0, *part_model.model, *holder)) {
      const std::vector<image_t> reg_image_ids = holder->RegImageIds();
      registered_image_ids.insert(reg_image_ids.begin(), reg_image_ids.end());
      LOG(INFO) << "A part merged into an earlier model of "
                << reg_image_ids.size() << " images";
      continue;
    }
    std::unordered_set<image_t> kept_image_ids;
    for (const image_t image_id : part_model.model->RegImageIds()) {
      if (registered_image_ids.count(image_id) == 0) {
        kept_image_ids.insert(image_id);
      }
    }
    std::shared_ptr<Reconstruction> model =
        RestrictToImages(kept_image_ids, std::move(part_model.model));
    if (model->NumRegImages() < 2) {
      LOG(WARNING) << "A part's model is left with fewer than 2 images that "
                      "no larger model holds: no model for it.";
      continue;
    }
    std::unordered_set<std::string> remaining_image_names;
    if (!options_.skip_registration &&
        (part_model.joined || !part_model.offered_communities.empty())) {
      std::vector<int> communities = part_model.communities;
      communities.insert(communities.end(),
                         part_model.offered_communities.begin(),
                         part_model.offered_communities.end());
      for (const int c : communities) {
        for (const image_t image_id : communities_.own_image_ids[c]) {
          if (registered_image_ids.count(image_id) == 0 &&
              !HasPosedImage(*model, image_id)) {
            remaining_image_names.insert(
                communities_.name_of_image.at(image_id));
          }
        }
      }
    }
    bool changed = part_model.joined;
    if (!remaining_image_names.empty()) {
      changed = RegisterIntoPart(remaining_image_names, &model) || changed;
    }
    if (changed && options_.incremental_options.extract_colors) {
      model->ExtractColorsForAllImages(
          options_.image_path, options_.incremental_options.num_threads);
    }
    const std::vector<image_t> reg_image_ids = model->RegImageIds();
    registered_image_ids.insert(reg_image_ids.begin(), reg_image_ids.end());
    result_.models.push_back(std::move(model));
  }
  std::stable_sort(result_.models.begin(),
                   result_.models.end(),
                   [](const std::shared_ptr<Reconstruction>& a,
                      const std::shared_ptr<Reconstruction>& b) {
                     return a->NumRegImages() > b->NumRegImages();
                   });
}

// COLMAP's incremental mapper continues `*model` with `image_names`; where
// that fails, the model stays as it was. Whether the model changed.
bool CommunityMerger::RegisterIntoPart(
    const std::unordered_set<std::string>& image_names,
    std::shared_ptr<Reconstruction>* model) const {
  LOG(INFO) << StringPrintf("Registering %d images into a model of %d images",
                            static_cast<int>(image_names.size()),
                            static_cast<int>((*model)->NumRegImages()));
  auto registered = std::make_shared<Reconstruction>(**model);
  try {
    auto mapper_options = std::make_shared<IncrementalPipelineOptions>(
        options_.incremental_options);
    mapper_options->extract_colors = false;
    const int num_new = RegisterRemainingImages(
        mapper_options,
        LoadPartCorrespondences(image_names, *registered),
        registered);
    LOG(INFO) << StringPrintf("%d images newly registered: %d in the model",
                              num_new,
                              static_cast<int>(registered->NumRegImages()));
  } catch (const std::exception& error) {
    LOG(ERROR) << "Registering the remaining images failed: " << error.what()
               << "; the model is kept without them.";
    return false;
  }
  *model = std::move(registered);
  return true;
}

std::shared_ptr<DatabaseCache> CommunityMerger::LoadPartCorrespondences(
    const std::unordered_set<std::string>& image_names,
    const Reconstruction& model) const {
  DatabaseCache::Options database_cache_options;
  database_cache_options.min_num_matches =
      static_cast<size_t>(options_.min_num_matches);
  database_cache_options.ignore_watermarks =
      options_.incremental_options.ignore_watermarks;
  database_cache_options.image_names = image_names;
  for (const image_t image_id : model.RegImageIds()) {
    database_cache_options.image_names.insert(model.Image(image_id).Name());
  }
  const std::shared_ptr<DatabaseCache> database_cache =
      CreateFilteredDatabaseCache(
          *Database::Open(options_.database_path),
          database_cache_options,
          [this](const image_t image_id1, const image_t image_id2) {
            return similarities_.false_pairs.count(
                       ImagePairToPairId(image_id1, image_id2)) == 0;
          });
  // Building the correspondence graph grows a vector per keypoint and
  // then flattens them; the freed vectors would stay resident through the
  // refinement (see ReleaseFreedMemory).
  ReleaseFreedMemory();
  for (const image_t image_id : model.RegImageIds()) {
    THROW_CHECK(database_cache->ExistsImage(image_id))
        << "image " << model.Image(image_id).Name()
        << " has no correspondences";
  }
  return database_cache;
}

// Joins the communities of one part (connected by kept similarities) into
// one model in the averaged frame, each with its own images.
std::shared_ptr<Reconstruction> CommunityMerger::JoinPart(
    const std::vector<int>& part_communities) {
  std::string ids;
  for (const int c : part_communities) ids += " " + std::to_string(c);
  LOG(INFO) << "Joining communities" << ids;
  std::vector<Reconstruction*> part_models;
  std::vector<Sim3d> world_from_community;
  std::vector<std::unordered_set<image_t>> owned_image_ids;
  std::unordered_set<image_t> part_image_ids;
  for (const int c : part_communities) {
    part_models.push_back(models_[c].get());
    world_from_community.push_back(averaging_.world_from_community[c]);
    owned_image_ids.push_back(communities_.own_image_ids[c]);
    part_image_ids.insert(owned_image_ids.back().begin(),
                          owned_image_ids.back().end());
  }
  // An image left without any pair (all contradicting the merge) cannot be
  // refined: it stays out. (The view graph tells, before the models are
  // joined and released, which images the correspondences will hold.)
  std::unordered_set<image_t> connected_image_ids;
  for (const ViewGraph::Edge& edge : view_graph_->Edges()) {
    const image_t image_id1 = view_graph_->ImageIds()[edge.vertex1];
    const image_t image_id2 = view_graph_->ImageIds()[edge.vertex2];
    if (part_image_ids.count(image_id1) && part_image_ids.count(image_id2) &&
        !similarities_.false_pairs.count(
            ImagePairToPairId(image_id1, image_id2))) {
      connected_image_ids.insert(image_id1);
      connected_image_ids.insert(image_id2);
    }
  }
  for (std::unordered_set<image_t>& image_ids : owned_image_ids) {
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
  auto merged = std::make_shared<Reconstruction>();
  JoinReconstructions(
      part_models, world_from_community, owned_image_ids, merged.get());
  merged->UpdatePoint3DErrors();
  LOG(INFO) << StringPrintf("Joined %d images and %d points",
                            static_cast<int>(merged->NumRegImages()),
                            static_cast<int>(merged->NumPoints3D()));
  return merged;
}

}  // namespace colmap
