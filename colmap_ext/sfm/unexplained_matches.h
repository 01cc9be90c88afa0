// Images a merged model places apart from the images they match.
//
// A verified image pair is explained by a model where most of its matches
// between two keypoints that both observe 3D points observe the same point:
// the model triangulated the pair's matches together. A community's mapper
// can register a group of its images onto a look-alike structure (on South
// Building, a stretch of facade; docs/design.md), triangulating their points
// there too: the group fits its own observations as well as any, and every
// check of the community's own model passes. In
// the merged model, where the neighbouring communities place the same
// structure right, the group's pairs with the images around it are not
// explained: their keypoints observe two copies of one structure, apart.
// Joined by explained pairs alone, the model's registered images then fall
// into groups; one that pairs join to the largest group, none of them
// explained, is placed apart from what its matches say, and is to be
// registered again against the rest (as the incremental mapper on the whole
// database registers them). A group that no pair with observed matches
// joins to the largest says nothing against its place: its link may only
// have lost its points.

#pragma once

#include "colmap/scene/correspondence_graph.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/util/types.h"

#include <vector>

namespace colmap {

// The registered images of `reconstruction` in groups apart from the
// largest (see above; pairs of `correspondence_graph`), in increasing
// order.
std::vector<image_t> FindImagesApartFromTheirMatches(
    const Reconstruction& reconstruction,
    const CorrespondenceGraph& correspondence_graph);

}  // namespace colmap
