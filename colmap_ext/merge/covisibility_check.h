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
// tested.

#pragma once

#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/util/types.h"

#include <functional>

namespace colmap {

struct CovisibilityCheckOptions {
  // Largest angle between the two images' rays to a point for it to count:
  // beyond about 45 degrees SIFT seldom matches (Morel and Yu, "ASIFT",
  // SIAM J. Imaging Sciences 2009). A wider bound rejects a right link at a
  // building's corner (PairsSeenUnderWideAnglesSayNothing); this one still
  // rejects alignments that stack identical towers.
  double max_ray_angle_deg = 45.0;

  // The alignment is rejected when the cross rate is below this fraction of
  // the internal rate... Low: a wrong alignment of identical structures has
  // almost no predicted pair verified, while a right link closing a walk
  // around a building (its ends see one facade from far apart) can have few.
  double min_rate_ratio = 0.05;

  // ...and at least this many cross pairs were predicted (fewer say
  // nothing either way).
  int min_num_predicted_pairs = 10;

  bool Check() const;
};

// Image pairs predicted co-visible and how many of them were verified.
struct PairCounts {
  int num_predicted = 0;
  int num_verified = 0;

  double Rate() const {
    return num_predicted == 0
               ? 0.0
               : static_cast<double>(num_verified) / num_predicted;
  }
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
// verified a pair (e.g. a view-graph edge), `is_compared_pair` whether it
// compared the two at all (COLMAP's matchers write a two-view geometry for
// every pair they compare; empty: every pair, as exhaustive matching). A pair
// never compared (beyond a sequential window, unretrieved) tells nothing and
// is not counted: else a true alignment of a sequence matched in a short
// window is rejected. Images registered in both are left out of the cross
// pairs.
CovisibilityCheck CheckCovisibility(
    const Reconstruction& reconstruction1,
    const Reconstruction& reconstruction2,
    const Sim3d& second_from_first,
    const std::function<bool(image_t, image_t)>& is_verified_pair,
    const std::function<bool(image_t, image_t)>& is_compared_pair,
    const CovisibilityCheckOptions& options);

}  // namespace colmap
