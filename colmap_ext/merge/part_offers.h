// Where the merge offers the images that no part of its own holds.
//
// The similarity averaging (similarity_averaging.h) splits the communities
// into parts: communities joined by kept similarities, numbered largest
// first. A part is one merged model. Two kinds of images have no part of
// their own to go to:
//   - those of a community without a model (its mapper registered nothing):
//     they are offered to the part that its view-graph edges lead to most;
//   - those of a part that no kept similarity joins to an earlier part
//     (larger, or as large) it has view-graph edges to, whether no
//     transform was found or the link was dropped: the part is offered to
//     the earlier part it has the most edges to, and onward to the part
//     that one is offered to (its images may join through the images that
//     join).
// The registration of the part they are offered to registers those it can,
// as COLMAP's incremental mapper tries to register every image into the
// model it grows (IncrementalMapper::RegisterNextImage), so a merge that
// cannot join two parts by a similarity still gives what the incremental
// mapper would. The images that register join that model; the offered part
// keeps only the others (community_merger.h).

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
