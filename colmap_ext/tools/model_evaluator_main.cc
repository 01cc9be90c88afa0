// model_evaluator: accuracy of a sparse model against ground-truth cameras.
//
//   model_evaluator --model_path OUT --ground_truth_path GT
//
// MODEL is a COLMAP model folder, or a folder of numbered models (OUT/0,
// OUT/1, ... as the mappers write them), in which case the model with the
// most registered images is evaluated and the number of models reported.
// Prints "key value" lines (see model_evaluation.h), to stdout and, with
// --output_path, to a file; --aligned_centers_path writes the aligned and
// true camera centres. --image_list_path (one image name per line, as
// COLMAP's image lists) aligns and measures those images alone, e.g. one
// community's in a merged model. For a ground truth with multi-camera rigs,
// rig_rotation_error_deg and rig_baseline_error_fraction give the error of
// the model's rig calibration (the largest over the rigs' cameras).

#include "colmap_ext/workflow/community_io.h"
#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/workflow/atomic_output.h"

#include "colmap/controllers/option_manager.h"
#include "colmap/util/file.h"
#include "colmap/util/string.h"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

namespace colmap {
namespace {

int RunModelEvaluator(int argc, char** argv) {
  std::string model_path;
  std::string ground_truth_path;
  std::string output_path;
  std::string aligned_centers_path;
  std::string image_list_path;
  ModelEvaluationOptions evaluation_options;

  OptionManager options(/*add_project_options=*/false);
  options.AddRequiredOption("model_path", &model_path);
  options.AddRequiredOption("ground_truth_path", &ground_truth_path);
  options.AddDefaultOption("output_path", &output_path);
  options.AddDefaultOption("aligned_centers_path", &aligned_centers_path);
  options.AddDefaultOption("image_list_path", &image_list_path);
  options.AddDefaultOption("alignment_max_error_fraction",
                           &evaluation_options.alignment_max_error_fraction);
  if (!options.Parse(argc, argv)) {
    return EXIT_FAILURE;
  }

  if (!IsModelDir(ground_truth_path)) {
    LOG(ERROR) << "No COLMAP model at --ground_truth_path "
               << ground_truth_path;
    return EXIT_FAILURE;
  }
  std::vector<std::string> model_dirs;
  if (IsModelDir(model_path)) {
    model_dirs.push_back(model_path);
  } else if (ExistsDir(model_path)) {
    for (int i = 0;; ++i) {
      const std::string dir =
          (std::filesystem::path(model_path) / std::to_string(i)).string();
      if (!ExistsDir(dir)) {
        break;
      }
      if (IsModelDir(dir)) {
        model_dirs.push_back(dir);
      }
    }
  }

  if (!image_list_path.empty()) {
    const std::string problem =
        ReadImageList(image_list_path, &evaluation_options.image_names);
    if (!problem.empty()) {
      LOG(ERROR) << problem;
      return EXIT_FAILURE;
    }
  }

  Reconstruction ground_truth;
  ground_truth.Read(ground_truth_path);

  // The model with the most registered images.
  auto best = std::make_unique<Reconstruction>();
  if (model_dirs.empty()) {
    LOG(WARNING) << "No COLMAP model at --model_path " << model_path;
  }
  for (const std::string& dir : model_dirs) {
    auto reconstruction = std::make_unique<Reconstruction>();
    reconstruction->Read(dir);
    if (reconstruction->NumRegImages() > best->NumRegImages()) {
      best = std::move(reconstruction);
    }
  }
  const ModelEvaluation evaluation =
      EvaluateModel(*best, ground_truth, evaluation_options);
  std::string text = ModelEvaluationToString(evaluation);
  text += StringPrintf("num_models %d\n", static_cast<int>(model_dirs.size()));

  if (!aligned_centers_path.empty()) {
    std::ofstream file(aligned_centers_path);
    THROW_CHECK_FILE_OPEN(file, aligned_centers_path);
    file << AlignedCentersToString(evaluation);
  }
  std::cout << text << std::flush;
  if (!output_path.empty()) {
    std::ofstream file(output_path);
    THROW_CHECK_FILE_OPEN(file, output_path);
    file << text;
  }
  return EXIT_SUCCESS;
}

}  // namespace
}  // namespace colmap

int main(int argc, char** argv) {
  colmap::InitializeGlog(argv);
  return colmap::RunModelEvaluator(argc, argv);
}
