// A DatabaseCache of a subset of a database's image pairs.
//
// CreateFilteredDatabaseCache loads what DatabaseCache::Create loads with the
// same options, without the pairs that `use_image_pair` refuses. Where Create
// reads every pair's matches first, it reads the inlier counts, then the
// geometries of the pairs in use one at a time (together first with
// `ignore_watermarks`): memory follows the subset. Pairs without inlier
// matches are never loaded (Create with `min_num_matches` 0 keeps them,
// without correspondences).

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
