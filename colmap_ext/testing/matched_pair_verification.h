// Geometric verification of a database's raw matches, as
// `colmap geometric_verifier` does it: for every image pair with matches
// and no two-view geometry, COLMAP's own EstimateTwoViewGeometry on the
// database's cameras and keypoints (essential, fundamental and homography
// matrices by LO-RANSAC, the configuration chosen by their inlier counts),
// and the result written as the verifier writes it: a pair with fewer than
// `min_num_inliers` inliers gets an empty two-view geometry. Unlike the
// verifier's worker threads, every pair's RANSAC is seeded from `seed` and
// the pair, so that the same database and seed give the same geometries.

#pragma once

#include "colmap/estimators/two_view_geometry.h"
#include "colmap/scene/database.h"

namespace colmap {

struct MatchedPairVerificationStats {
  int num_matched_pairs = 0;
  int num_verified_pairs = 0;
  size_t num_matches = 0;
  size_t num_inlier_matches = 0;
};

MatchedPairVerificationStats VerifyMatchedPairs(
    const TwoViewGeometryOptions& options,
    unsigned int seed,
    int num_threads,
    Database* database);

}  // namespace colmap
