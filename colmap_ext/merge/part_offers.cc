#include "colmap_ext/merge/part_offers.h"

#include "colmap/util/logging.h"

#include <algorithm>

namespace colmap {
namespace {

// The key with the largest count (the first of equal ones).
int MostCounted(const std::map<int, size_t>& counts) {
  return std::max_element(
             counts.begin(),
             counts.end(),
             [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

}  // namespace

PartOffers PlanPartOffers(const std::vector<int>& part_of_community,
                          const std::vector<bool>& has_model,
                          const CrossEdges& cross_edges) {
  THROW_CHECK_EQ(part_of_community.size(), has_model.size());
  const int num_communities = static_cast<int>(has_model.size());
  PartOffers offers;

  // A community without a model: to the part its edges lead to most.
  std::map<int, std::map<int, size_t>> num_edges_to_part;
  for (const auto& pair_and_edges : cross_edges) {
    const std::pair<int, int>& pair = pair_and_edges.first;
    THROW_CHECK_LT(pair.second, num_communities);
    if (has_model[pair.first] != has_model[pair.second]) {
      const int unmodelled = has_model[pair.first] ? pair.second : pair.first;
      const int modelled = has_model[pair.first] ? pair.first : pair.second;
      num_edges_to_part[unmodelled][part_of_community[modelled]] +=
          pair_and_edges.second.size();
    }
  }
  for (const auto& community_and_counts : num_edges_to_part) {
    const int community = community_and_counts.first;
    const int best_part = MostCounted(community_and_counts.second);
    offers.image_communities_of_part[best_part].push_back(community);
  }

  // A part that no similarity joins to an earlier one it has edges to: to
  // the earlier part it has the most edges to, and onward.
  std::map<int, std::map<int, size_t>> num_edges_between_parts;
  for (const auto& pair_and_edges : cross_edges) {
    const std::pair<int, int>& pair = pair_and_edges.first;
    if (!has_model[pair.first] || !has_model[pair.second]) {
      continue;
    }
    const int part1 = part_of_community[pair.first];
    const int part2 = part_of_community[pair.second];
    if (part1 != part2) {
      num_edges_between_parts[std::max(part1, part2)][std::min(part1, part2)] +=
          pair_and_edges.second.size();
    }
  }
  std::map<int, int> offered_to_part;
  for (const auto& part_and_counts : num_edges_between_parts) {
    offered_to_part[part_and_counts.first] =
        MostCounted(part_and_counts.second);
  }
  for (const auto& part_and_target : offered_to_part) {
    const int part = part_and_target.first;
    LOG(INFO) << "No similarity joins part " << part
              << " to an earlier part: its images are offered to part "
              << part_and_target.second << "";
    for (auto target = offered_to_part.find(part);
         target != offered_to_part.end();
         target = offered_to_part.find(target->second)) {
      for (int c = 0; c < num_communities; ++c) {
        if (has_model[c] && part_of_community[c] == part) {
          offers.image_communities_of_part[target->second].push_back(c);
        }
      }
    }
  }
  return offers;
}

}  // namespace colmap
