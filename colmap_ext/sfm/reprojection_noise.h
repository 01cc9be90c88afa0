// The reprojection noise of a model, and an outlier threshold relative to it.
//
// The incremental mapper filters observations at a fixed reprojection error
// (--Mapper.filter_max_reproj_error, 4 px by default) whatever the model's
// noise. Where keypoints are localised to a few tenths of a pixel (real
// photographs at 1024 px: a median error of 0.2 px), 4 px is about twenty
// standard deviations, and the observations between a few deviations and
// 4 px (a keypoint on a different corner, a repeated texture a few pixels
// off) are kept and weigh in every least squares adjustment; in a long open
// sequence, whose far end hangs on a few such observations, they bend it.
//
// With residuals per image coordinate Gaussian of standard deviation sigma,
// the reprojection error (their norm) follows a Rayleigh distribution whose
// median is sigma * sqrt(2 ln 2); the median error over all observations,
// insensitive to the outliers, estimates sigma. Observations farther than a
// multiple of it are outliers at that level of significance (an error above
// k sigma has probability exp(-k^2 / 2) under the Gaussian).

#pragma once

#include "colmap/scene/reconstruction.h"

namespace colmap {

// sigma as above, in pixels, from at most `max_num_observations`
// observations spread evenly over the points (so that a model of millions of
// observations needs little memory). 0 for a model without observations.
double EstimateReprojectionNoise(const Reconstruction& reconstruction,
                                 size_t max_num_observations = 1000000);

// noise_multiple * sigma, bounded to [min_reproj_error, max_reproj_error]:
// the threshold at which to filter `reconstruction`'s observations;
// `max_reproj_error` alone for a noise_multiple of 0 or a model without
// observations. The lower bound keeps a model whose residuals are nearly
// zero (noise-free generated data, or points of two observations each,
// which absorb most of their noise) from losing its observations to a
// threshold of nothing.
double NoiseRelativeReprojectionThreshold(const Reconstruction& reconstruction,
                                          double noise_multiple,
                                          double min_reproj_error,
                                          double max_reproj_error);

}  // namespace colmap
