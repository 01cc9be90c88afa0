#include "colmap_ext/sfm/community_judgement.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

CommunityModelReport Report(const int num_images,
                            const int num_registered,
                            const int num_models,
                            const double error) {
  CommunityModelReport report;
  report.num_images = num_images;
  report.num_registered = num_registered;
  report.num_models = num_models;
  report.mean_reprojection_error = error;
  return report;
}

TEST(JudgeCommunityModels, FewRegisteredImagesDoubtfulLargeErrorsBroken) {
  const std::vector<CommunityJudgement> judgements =
      JudgeCommunityModels({Report(100, 99, 1, 0.75),
                            Report(80, 68, 3, 0.78),
                            Report(60, 60, 1, 1.30),
                            Report(50, 46, 2, 0.70),
                            Report(30, 0, 0, 0.0)},
                           CommunityJudgementOptions());
  ASSERT_EQ(judgements.size(), 5);
  EXPECT_FALSE(judgements[0].doubtful);
  EXPECT_FALSE(judgements[0].broken);
  EXPECT_TRUE(judgements[0].reason.empty());
  EXPECT_TRUE(judgements[1].doubtful);
  EXPECT_FALSE(judgements[1].broken);
  EXPECT_EQ(judgements[1].reason,
            "registered 68 of 80 images in the largest of 3 models");
  EXPECT_FALSE(judgements[2].doubtful);
  EXPECT_TRUE(judgements[2].broken);
  EXPECT_EQ(judgements[2].reason,
            "mean reprojection error 1.30 px, 1.7x the median");
  // 92% registered, even in the largest of two models, is enough.
  EXPECT_FALSE(judgements[3].doubtful);
  // No model, nothing to judge.
  EXPECT_FALSE(judgements[4].doubtful);
  EXPECT_FALSE(judgements[4].broken);
}

TEST(JudgeCommunityModels, RegisteredFractionIsJudgedAgainstTheOthers) {
  // Every community left about 15% of its images out: that is the data.
  // The one that left 30% out is in doubt.
  const std::vector<CommunityJudgement> judgements =
      JudgeCommunityModels({Report(114, 99, 1, 0.79),
                            Report(90, 75, 2, 0.78),
                            Report(77, 65, 1, 0.71),
                            Report(51, 36, 2, 0.74)},
                           CommunityJudgementOptions());
  EXPECT_FALSE(judgements[0].doubtful);
  EXPECT_FALSE(judgements[1].doubtful);
  EXPECT_FALSE(judgements[2].doubtful);
  EXPECT_TRUE(judgements[3].doubtful);
  EXPECT_EQ(judgements[3].reason,
            "registered 36 of 51 images in the largest of 2 models");
}

TEST(CommunityJudgementOptions, Check) {
  CommunityJudgementOptions options;
  EXPECT_TRUE(options.Check());
  options.max_relative_reprojection_error = 0.5;
  EXPECT_FALSE(options.Check());
}

}  // namespace
}  // namespace colmap
