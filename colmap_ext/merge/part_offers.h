// Where the merge offers the images that no part of its own holds.
//
// The images of a community without a model are offered to the part
// (similarity_averaging.h) its view-graph edges lead to most; a part that no
// kept similarity joins to an earlier part (larger, or as large) it has edges
// to is offered to the one it has most edges to, and onward. That part's
// registration (community_merger.h) registers those it can. docs/design.md,
// Merge stage 4, gives the reasons.

#pragma once

#include "colmap_ext/merge/community_alignment.h"

#include <map>
#include <vector>

namespace colmap {

struct PartOffers {
  // By part: the communities whose own images are offered to it.
  std::map<int, std::vector<int>> image_communities_of_part;
};

// `part_of_community[c]` is community c's part (used only where
// `has_model[c]`); `cross_edges` the view-graph edges between communities.
PartOffers PlanPartOffers(const std::vector<int>& part_of_community,
                          const std::vector<bool>& has_model,
                          const CrossEdges& cross_edges);

}  // namespace colmap
