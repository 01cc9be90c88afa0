#include "colmap_ext/sfm/reprojection_noise.h"

#include "colmap/math/random.h"
#include "colmap/scene/projection.h"
#include "colmap/scene/synthetic.h"

#include <cmath>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// COLMAP's synthetic scene at its true poses and points, with keypoints
// displaced by Gaussian noise of `stddev` pixels per coordinate.
Reconstruction NoisyScene(const double stddev) {
  SetPRNGSeed(3);
  SyntheticDatasetOptions options;
  options.num_rigs = 2;
  options.num_cameras_per_rig = 1;
  options.num_frames_per_rig = 5;
  options.num_points3D = 2000;
  Reconstruction model;
  SynthesizeDataset(options, &model);
  SyntheticNoiseOptions noise_options;
  noise_options.point2D_stddev = stddev;
  SynthesizeNoise(noise_options, &model);
  return model;
}

double ReprojectionError(const Reconstruction& model,
                         const Point3D& point3D,
                         const TrackElement& track_el) {
  const Image& image = model.Image(track_el.image_id);
  return std::sqrt(
      CalculateSquaredReprojectionError(image.Point2D(track_el.point2D_idx).xy,
                                        point3D.xyz,
                                        image.CamFromWorld(),
                                        model.Camera(image.CameraId())));
}

TEST(EstimateReprojectionNoise, RecoversTheKeypointNoise) {
  for (const double stddev : {0.2, 1.0}) {
    const Reconstruction model = NoisyScene(stddev);
    EXPECT_NEAR(EstimateReprojectionNoise(model), stddev, 0.05 * stddev);
    // From a sample of the observations, about as well.
    EXPECT_NEAR(EstimateReprojectionNoise(model, /*max_num_observations=*/997),
                stddev,
                0.1 * stddev);
  }
}

TEST(EstimateReprojectionNoise, IgnoresOutliers) {
  Reconstruction model = NoisyScene(0.3);
  // One observation in ten moved 10-30 px away.
  size_t index = 0;
  for (const auto& point3D : model.Points3D()) {
    for (const TrackElement& track_el : point3D.second.track.Elements()) {
      if (index++ % 10 == 0) {
        Point2D& point2D =
            model.Image(track_el.image_id).Point2D(track_el.point2D_idx);
        point2D.xy += Eigen::Vector2d(10 + index % 20, -5);
      }
    }
  }
  EXPECT_NEAR(EstimateReprojectionNoise(model), 0.3, 0.05);
}

TEST(EstimateReprojectionNoise, IsZeroWithoutObservations) {
  Reconstruction model;
  EXPECT_EQ(EstimateReprojectionNoise(model), 0);
  EXPECT_EQ(NoiseRelativeReprojectionThreshold(model, 4, 1, 4), 4);
}

TEST(NoiseRelativeReprojectionThreshold, IsBoundedByTheFixedThreshold) {
  const Reconstruction model = NoisyScene(0.25);
  const double sigma = EstimateReprojectionNoise(model);
  EXPECT_DOUBLE_EQ(NoiseRelativeReprojectionThreshold(model, 6, 0.5, 4),
                   6 * sigma);
  // A noisier model, or a small fixed threshold: the fixed one.
  EXPECT_EQ(NoiseRelativeReprojectionThreshold(model, 6, 0.5, 1), 1);
  EXPECT_EQ(NoiseRelativeReprojectionThreshold(model, 0, 0.5, 4), 4);
  // A model with hardly any noise: the lower bound.
  EXPECT_EQ(NoiseRelativeReprojectionThreshold(NoisyScene(1e-6), 6, 0.5, 4),
            0.5);
  // At six standard deviations no inlier is beyond it (probability 1.5e-8
  // each); every observation moved 3 px is.
  const double threshold = NoiseRelativeReprojectionThreshold(model, 6, 0.5, 4);
  for (const auto& point3D : model.Points3D()) {
    for (const TrackElement& track_el : point3D.second.track.Elements()) {
      EXPECT_LT(ReprojectionError(model, point3D.second, track_el), threshold);
    }
  }
  EXPECT_LT(threshold, 3 - 4 * 0.25);
}

}  // namespace
}  // namespace colmap
