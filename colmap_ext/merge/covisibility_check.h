// Does an alignment of two reconstructions explain which images were matched?
//
// Matches between identical structures (two facades, two towers) agree with
// the transform that stacks one on the other. What gives such a merge away
// is what is missing (Zach, Irschara and Bischof, CVPR 2008; Heinly et al.,
// ECCV 2014): once aligned, many image pairs across the two models would see
// the same structure, but the matcher verified few of them. With both models
// in one frame, a pair is predicted co-visible where each image sees at least
// 15 of the other's points (of at most 200 per image) in front of it, inside
// it, not behind its own surfaces (a coarse depth map) and under rays less
// than `max_ray_angle_deg` apart. The check compares
//   cross rate    = verified / predicted co-visible pairs across the models,
//   internal rate = verified / predicted co-visible pairs within each model,
// so that the matcher's habits (exhaustive, sequential, retrieval) cancel.
// Only pairs closer than the longest verified pairs inside the models are
// tested. Close views (`close_ray_angle_deg`) are counted for the log only.

#pragma once

#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/util/types.h"

#include <functional>

namespace colmap {

struct CovisibilityCheckOptions {
  // Largest angle between the two images' rays to a point for it to count:
  // beyond about 45 degrees of viewpoint change SIFT seldom matches
  // (Morel and Yu, "ASIFT", SIAM J. Imaging Sciences 2009), and an
  // unmatched pair there says nothing about the alignment. With a wider
  // bound, a right link at the corner of a building, whose two sides the
  // matcher does not match across, is rejected on such pairs; at this one,
  // alignments that stack identical towers are still rejected
  // (PairsSeenUnderWideAnglesSayNothing is the corner).
  double max_ray_angle_deg = 45.0;

  // Pairs are tested up to this quantile of the centre distances of the
  // verified pairs inside the models.
  double max_distance_quantile = 0.9;

  // The alignment is rejected when the cross rate is below this fraction of
  // the internal rate... The default is low: a wrong alignment of identical
  // structures predicts pairs almost none of which were verified, while a
  // right link that closes a walk around a building, whose start and end
  // see the same facade from far apart, can have few of its pairs verified;
  // a higher bound rejects such a link and leaves the loop open.
  double min_rate_ratio = 0.05;

  // ...and at least this many cross pairs were predicted (fewer say
  // nothing either way).
  int min_num_predicted_pairs = 10;

  // Pairs whose rays to the points they would share are on average at most
  // this many degrees apart are close views, counted apart for the log only
  // (no rule uses them). The matcher verifies nearly every close view but
  // misses many wide ones (for want of resolution, at a corner or in
  // another light), so the counts show whether a rejection rests on wide
  // views alone.
  double close_ray_angle_deg = 20.0;

  bool Check() const;
};

// Image pairs predicted co-visible and how many of them were verified, and
// the same for the close views among them
// (CovisibilityCheckOptions::close_ray_angle_deg), for the log.
struct PairCounts {
  int num_predicted = 0;
  int num_verified = 0;
  int num_predicted_close = 0;
  int num_verified_close = 0;

  // num_verified / num_predicted (0 without predicted pairs).
  double Rate() const;
};

struct CovisibilityCheck {
  // The pairs across the two models (the cross rate) and inside each model
  // (the internal rate).
  PairCounts cross;
  PairCounts internal;
  // Whether the alignment explains the matches (true where there are too few
  // predicted pairs to tell).
  bool consistent = true;
};

// `is_verified_pair(image_id1, image_id2)` tells whether the matcher
// verified a pair (e.g. an edge of the view graph), `is_compared_pair`
// whether it compared the two images at all (verified or not: COLMAP's
// matchers write a two-view geometry for every pair they compare). A pair
// it never compared (sequential matching beyond its window, a vocabulary
// tree's unretrieved pairs) tells nothing and is counted neither as
// predicted nor as verified; without `is_compared_pair` every pair was
// compared (exhaustive matching). Without it, a true alignment of an open
// sequence matched only within a short window is rejected on pairs never
// compared, which leaves two models where colmap mapper has one. Images
// registered in both reconstructions are left out of the cross pairs.
CovisibilityCheck CheckCovisibility(
    const Reconstruction& reconstruction1,
    const Reconstruction& reconstruction2,
    const Sim3d& second_from_first,
    const std::function<bool(image_t, image_t)>& is_verified_pair,
    const std::function<bool(image_t, image_t)>& is_compared_pair,
    const CovisibilityCheckOptions& options);

}  // namespace colmap
