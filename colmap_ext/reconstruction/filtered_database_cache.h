// A DatabaseCache of a subset of a database's image pairs.
//
// DatabaseCache::Create reads every image pair's two-view geometry, inlier
// matches included, and only then keeps the pairs among the requested
// images: a community of a large database holds the whole database's
// matches for a moment. The community mapper also needs to leave pairs out
// of its merged model's correspondence graph: those whose matches
// contradict the merge (e.g. matches between two identical facades).
//
// CreateFilteredDatabaseCache loads what DatabaseCache::Create loads (rigs,
// cameras, frames, images with their keypoints, pose priors, and the
// correspondence graph of the image pairs with at least
// `options.min_num_matches` inlier matches among the frames of
// `options.image_names`, watermark pairs left out with
// `options.ignore_watermarks`), without the pairs that `use_image_pair`
// refuses. It reads the inlier count of every pair first, then the two-view
// geometry of each pair in use only, and adds it to the correspondence graph
// as it is read (with `ignore_watermarks`, the geometries of the pairs in use
// are read together first, as each one's configuration decides whether it is
// used): a subset of a large database costs memory in proportion to the
// subset, and the load's peak holds one pair's matches beside the graph.
//
// Pairs without any inlier match are never loaded (the database lists inlier
// counts of pairs that have some), where DatabaseCache::Create with
// `min_num_matches` 0 keeps them, without correspondences.

#pragma once

#include "colmap/scene/database.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/types.h"

#include <functional>
#include <memory>

namespace colmap {

// `use_image_pair(image_id1, image_id2)` is asked with the two images in the
// order of their pair id; unset, every pair is used.
std::shared_ptr<DatabaseCache> CreateFilteredDatabaseCache(
    const Database& database,
    const DatabaseCache::Options& options,
    const std::function<bool(image_t, image_t)>& use_image_pair = {});

}  // namespace colmap
