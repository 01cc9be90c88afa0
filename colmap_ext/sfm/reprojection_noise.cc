#include "colmap_ext/sfm/reprojection_noise.h"

#include "colmap/scene/projection.h"
#include "colmap/util/logging.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace colmap {

double EstimateReprojectionNoise(const Reconstruction& reconstruction,
                                 const size_t max_num_observations) {
  THROW_CHECK_GT(max_num_observations, 0);
  const size_t num_observations = reconstruction.ComputeNumObservations();
  if (num_observations == 0) {
    return 0;
  }
  // Every stride-th observation, in the order of the points and their tracks.
  const size_t stride =
      (num_observations + max_num_observations - 1) / max_num_observations;
  std::vector<double> errors;
  errors.reserve(num_observations / stride + 1);
  size_t index = 0;
  for (const auto& point3D : reconstruction.Points3D()) {
    for (const TrackElement& track_el : point3D.second.track.Elements()) {
      if (index++ % stride != 0) {
        continue;
      }
      const Image& image = reconstruction.Image(track_el.image_id);
      const double squared_error = CalculateSquaredReprojectionError(
          image.Point2D(track_el.point2D_idx).xy,
          point3D.second.xyz,
          image.CamFromWorld(),
          reconstruction.Camera(image.CameraId()));
      // A point behind its camera has an infinite error: above the median.
      errors.push_back(std::sqrt(squared_error));
    }
  }
  const auto median = errors.begin() + errors.size() / 2;
  std::nth_element(errors.begin(), median, errors.end());
  return *median / std::sqrt(2 * std::log(2.0));
}

double NoiseRelativeReprojectionThreshold(const Reconstruction& reconstruction,
                                          const double noise_multiple,
                                          const double min_reproj_error,
                                          const double max_reproj_error) {
  THROW_CHECK_GE(noise_multiple, 0);
  THROW_CHECK_GE(min_reproj_error, 0);
  THROW_CHECK_GT(max_reproj_error, 0);
  if (noise_multiple == 0) {
    return max_reproj_error;
  }
  const double sigma = EstimateReprojectionNoise(reconstruction);
  if (sigma <= 0) {
    return max_reproj_error;
  }
  return std::min(max_reproj_error,
                  std::max(min_reproj_error, noise_multiple * sigma));
}

}  // namespace colmap
