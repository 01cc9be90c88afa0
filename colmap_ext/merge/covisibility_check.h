// Does an alignment of two reconstructions explain which images were matched?
//
// A similarity between two community models can be supported by many
// inlier correspondences and still be wrong: matches between two identical
// facades (repeated structure) agree with the transform that stacks one
// facade on the other, as true matches agree with the true transform. What
// gives such a merge away is what is missing (Zach, Irschara and Bischof,
// "What can missing correspondences tell us about 3D structure and motion?",
// CVPR 2008; Heinly et al., "Correcting for duplicate scene structure in
// sparse 3D reconstruction", ECCV 2014): once aligned, many image pairs
// across the two models would see the same structure, but the matcher
// verified few of them.
//
// Here the question is asked per image pair. With both models in one frame,
// a pair of images is predicted co-visible when each sees at least
// 15 of the other's 3D points (of at most 200 per image, evenly chosen) in
// front of it, inside its
// image, not behind the surfaces it sees there itself (a coarse depth map
// from its own points; where it sees nothing, nothing is predicted), under
// rays less than `max_ray_angle_deg` apart (features are not matched
// across larger viewpoint changes). The check compares
//   cross rate    = verified / predicted co-visible pairs across the models,
//   internal rate = verified / predicted co-visible pairs within each model,
// so that the matcher's own habits (exhaustive, sequential, vocabulary tree)
// cancel out: a true alignment predicts cross pairs that the matcher verified
// about as often as it verified the predicted pairs inside the models, a
// false one predicts many pairs it never verified. (Where every pair of the
// duplicates was verified, the pairs alone cannot tell; that would need the
// matches of each pair, point by point.) Only pairs whose camera centres
// are closer than the longest verified pairs inside the models are tested,
// so the cost follows the images near the border, and drift far from it
// does not matter. The close views among the pairs (rays to their common
// points at most `close_ray_angle_deg` apart on average) are counted
// apart, for the log only: no rule uses them.

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

struct CovisibilityCheck {
  int num_predicted_cross_pairs = 0;
  int num_verified_cross_pairs = 0;
  int num_predicted_internal_pairs = 0;
  int num_verified_internal_pairs = 0;

  // The same counts for the close views alone
  // (CovisibilityCheckOptions::close_ray_angle_deg), for the log.
  int num_predicted_close_cross_pairs = 0;
  int num_verified_close_cross_pairs = 0;
  int num_predicted_close_internal_pairs = 0;
  int num_verified_close_internal_pairs = 0;

  double CrossRate() const;
  double InternalRate() const;
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
