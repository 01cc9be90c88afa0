// model_adjuster: global bundle adjustment of a sparse model, as the
// community mapper's refinement runs it at any size.
//
//   model_adjuster --input_path M --output_path OUT
//                  [--max_num_iterations 10]
//                  [--function_tolerance 1e-10]
//                  [--initial_trust_region_radius 1e4]
//
// All registered images are adjusted with all their observations, the gauge
// held as COLMAP's mapper holds it (the first registered image's pose, one
// coordinate of the second's position), intrinsics refined as by
// `colmap bundle_adjuster`'s defaults, squared loss, Ceres' sparse Schur
// solver. `colmap bundle_adjuster` switches to the iterative Schur solver
// above 1000 images, whose inexact steps follow weakly constrained
// directions poorly: this tool lets the cost of two models of thousands of
// images be compared on the same footing (scripts/ground_truth_start.py).
// Prints "key value" lines: the Ceres cost (half the sum of squared
// residuals) before and after, with all its digits, the RMS reprojection
// error, iterations and how the solver stopped.

#include "colmap_ext/sfm/reduced_bundle_adjustment.h"
#include "colmap_ext/util/atomic_output.h"

#include "colmap/controllers/option_manager.h"
#include "colmap/estimators/bundle_adjustment_ceres.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/util/file.h"
#include "colmap/util/timer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <ceres/ceres.h>

namespace colmap {
namespace {

int RunModelAdjuster(int argc, char** argv) {
  std::string input_path;
  std::string output_path;
  int max_num_iterations = 10;
  double function_tolerance = 1e-10;
  double initial_trust_region_radius = 1e4;

  OptionManager options(/*add_project_options=*/false);
  options.AddRequiredOption("input_path", &input_path);
  options.AddRequiredOption("output_path", &output_path);
  options.AddDefaultOption("max_num_iterations", &max_num_iterations);
  options.AddDefaultOption("function_tolerance", &function_tolerance);
  options.AddDefaultOption("initial_trust_region_radius",
                           &initial_trust_region_radius);
  if (!options.Parse(argc, argv)) {
    return EXIT_FAILURE;
  }

  if (!IsModelDir(input_path)) {
    LOG(ERROR) << "No COLMAP model at --input_path " << input_path;
    return EXIT_FAILURE;
  }
  if (!ExistsDir(output_path)) {
    LOG(ERROR) << "--output_path " << output_path
               << " is not a folder: create it first";
    return EXIT_FAILURE;
  }
  if (max_num_iterations < 1 || function_tolerance < 0 ||
      initial_trust_region_radius <= 0) {
    LOG(ERROR) << "--max_num_iterations must be at least 1, "
                  "--function_tolerance at least 0 and "
                  "--initial_trust_region_radius above 0";
    return EXIT_FAILURE;
  }

  Reconstruction reconstruction;
  reconstruction.Read(input_path);
  if (reconstruction.NumRegImages() < 2) {
    LOG(ERROR) << "The model at " << input_path
               << " has fewer than two registered images";
    return EXIT_FAILURE;
  }

  const BundleAdjustmentOptions ba_options;
  ceres::Solver::Options solver_options = ba_options.ceres->solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  solver_options.max_num_iterations = max_num_iterations;
  solver_options.function_tolerance = function_tolerance;
  solver_options.initial_trust_region_radius = initial_trust_region_radius;
  Timer timer;
  timer.Start();
  const ceres::Solver::Summary summary =
      AdjustAllObservations(ba_options, solver_options, &reconstruction);
  if (summary.num_residuals <= 0) {
    LOG(ERROR) << "The model at " << input_path << " has no observations";
    return EXIT_FAILURE;
  }
  // Written beside the output and renamed into place file by file, so that
  // the model there (the input itself, if asked) is never half-written.
  const std::filesystem::path temporary =
      output_path + ".tmp-model_adjuster";
  std::filesystem::create_directories(temporary);
  reconstruction.WriteBinary(temporary);
  for (const char* name : {"rigs.bin",
                           "cameras.bin",
                           "frames.bin",
                           "images.bin",
                           "points3D.bin"}) {
    std::filesystem::rename(temporary / name,
                            std::filesystem::path(output_path) / name);
  }
  std::filesystem::remove(temporary);

  const double num_residuals = std::max(1, summary.num_residuals_reduced);
  std::printf("num_residuals %d\n", summary.num_residuals_reduced);
  std::printf("initial_cost %.10e\n", summary.initial_cost);
  std::printf("final_cost %.10e\n", summary.final_cost);
  std::printf("initial_rms_px %.9f\n",
              std::sqrt(2 * summary.initial_cost / num_residuals));
  std::printf("final_rms_px %.9f\n",
              std::sqrt(2 * summary.final_cost / num_residuals));
  std::printf("iterations %d\n",
              static_cast<int>(summary.iterations.size()) - 1);
  std::printf("termination %s\n",
              summary.termination_type == ceres::CONVERGENCE
                  ? "converged"
                  : (summary.termination_type == ceres::NO_CONVERGENCE
                         ? "iteration_limit"
                         : "failed"));
  std::printf("seconds %.1f\n", timer.ElapsedSeconds());
  return summary.IsSolutionUsable() ? EXIT_SUCCESS : EXIT_FAILURE;
}

}  // namespace
}  // namespace colmap

int main(int argc, char** argv) {
  colmap::InitializeGlog(argv);
  return colmap::RunModelAdjuster(argc, argv);
}
