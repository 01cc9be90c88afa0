#include "colmap_ext/sfm/community_judgement.h"

#include "colmap/math/math.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>

namespace colmap {

bool CommunityJudgementOptions::Check() const {
  CHECK_OPTION_GE(min_registered_fraction, 0);
  CHECK_OPTION_LE(min_registered_fraction, 1);
  CHECK_OPTION_GE(max_relative_reprojection_error, 1);
  return true;
}

std::vector<CommunityJudgement> JudgeCommunityModels(
    const std::vector<CommunityModelReport>& reports,
    const CommunityJudgementOptions& options) {
  THROW_CHECK(options.Check());
  std::vector<double> errors;
  std::vector<double> fractions;
  for (const CommunityModelReport& report : reports) {
    if (report.num_registered > 0 && report.model_index == 1) {
      errors.push_back(report.mean_reprojection_error);
      fractions.push_back(static_cast<double>(report.num_registered) /
                          std::max(1, report.num_images));
    }
  }
  const double median_error = errors.empty() ? 0.0 : Median(errors);
  const double median_fraction = fractions.empty() ? 0.0 : Median(fractions);

  std::vector<CommunityJudgement> judgements(reports.size());
  for (size_t c = 0; c < reports.size(); ++c) {
    const CommunityModelReport& report = reports[c];
    if (report.num_registered == 0) {
      continue;
    }
    CommunityJudgement& judgement = judgements[c];
    if (report.model_index > 1) {
      judgement.doubtful = true;
      judgement.reason = StringPrintf("model %d of %d, %d of %d images",
                                      report.model_index,
                                      report.num_models,
                                      report.num_registered,
                                      report.num_images);
    } else if (report.num_registered < options.min_registered_fraction *
                                           median_fraction *
                                           report.num_images) {
      judgement.doubtful = true;
      judgement.reason = StringPrintf(
          "registered %d of %d images%s",
          report.num_registered,
          report.num_images,
          report.num_models > 1
              ? StringPrintf(" in the largest of %d models", report.num_models)
                    .c_str()
              : "");
    }
    if (report.mean_reprojection_error >
        options.max_relative_reprojection_error * median_error) {
      judgement.broken = true;
      judgement.reason +=
          (judgement.reason.empty() ? "" : "; ") +
          StringPrintf("mean reprojection error %.2f px, %.1fx the median",
                       report.mean_reprojection_error,
                       report.mean_reprojection_error / median_error);
    }
  }
  return judgements;
}

}  // namespace colmap
