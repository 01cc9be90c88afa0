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
  for (const auto& [pair, edges] : cross_edges) {
    THROW_CHECK_LT(pair.second, num_communities);
    if (has_model[pair.first] != has_model[pair.second]) {
      const int unmodelled = has_model[pair.first] ? pair.second : pair.first;
      const int modelled = has_model[pair.first] ? pair.first : pair.second;
      num_edges_to_part[unmodelled][part_of_community[modelled]] +=
          edges.size();
    }
  }
  for (const auto& [community, counts] : num_edges_to_part) {
    offers.image_communities_of_part[MostCounted(counts)].push_back(community);
  }

  // A part that no similarity joins to an earlier one it has edges to: to
  // the earlier part it has the most edges to, and onward.
  std::map<int, std::map<int, size_t>> num_edges_between_parts;
  for (const auto& [pair, edges] : cross_edges) {
    if (!has_model[pair.first] || !has_model[pair.second]) {
      continue;
    }
    const int part1 = part_of_community[pair.first];
    const int part2 = part_of_community[pair.second];
    if (part1 != part2) {
      num_edges_between_parts[std::max(part1, part2)][std::min(part1, part2)] +=
          edges.size();
    }
  }
  std::map<int, int> offered_to_part;
  for (const auto& [part, counts] : num_edges_between_parts) {
    offered_to_part[part] = MostCounted(counts);
  }
  for (const auto& [part, first_target] : offered_to_part) {
    LOG(INFO) << "No similarity joins part " << part
              << " to an earlier part: its images are offered to part "
              << first_target;
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
