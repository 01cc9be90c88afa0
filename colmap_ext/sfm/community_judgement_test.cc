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

TEST(JudgeCommunityModels, OtherModelsAreInDoubtAndSetNoMedian) {
  // Community 0 broke into models of 38 and 28 of its 66 images; the second
  // takes part as an extra community.
  CommunityModelReport second = Report(66, 28, 2, 0.80);
  second.model_index = 2;
  CommunityModelReport broken_third = Report(66, 12, 3, 1.60);
  broken_third.model_index = 3;
  CommunityModelReport many_errors = Report(66, 20, 3, 2.0);
  many_errors.model_index = 3;
  const std::vector<CommunityJudgement> judgements =
      JudgeCommunityModels({Report(66, 38, 2, 0.75),
                            Report(40, 40, 1, 0.70),
                            Report(30, 29, 1, 0.72),
                            second,
                            broken_third},
                           CommunityJudgementOptions());
  ASSERT_EQ(judgements.size(), 5);
  EXPECT_TRUE(judgements[0].doubtful);
  EXPECT_FALSE(judgements[1].doubtful);
  EXPECT_FALSE(judgements[2].doubtful);
  EXPECT_TRUE(judgements[3].doubtful);
  EXPECT_FALSE(judgements[3].broken);
  EXPECT_EQ(judgements[3].reason, "model 2 of 2, 28 of 66 images");
  // Broken against the median of the largest models (0.72 px): 2.2x.
  EXPECT_TRUE(judgements[4].broken);
  EXPECT_EQ(judgements[4].reason,
            "model 3 of 3, 12 of 66 images; mean reprojection error 1.60 px, "
            "2.2x the median");
  // The extra communities do not move the medians: the same verdicts on
  // the largest models with a third extra community of large errors.
  const std::vector<CommunityJudgement> with_more =
      JudgeCommunityModels({Report(66, 38, 2, 0.75),
                            Report(40, 40, 1, 0.70),
                            Report(30, 29, 1, 0.72),
                            second,
                            broken_third,
                            many_errors},
                           CommunityJudgementOptions());
  for (int c = 0; c < 5; ++c) {
    EXPECT_EQ(with_more[c].doubtful, judgements[c].doubtful);
    EXPECT_EQ(with_more[c].reason, judgements[c].reason);
  }
}

TEST(CommunityJudgementOptions, Check) {
  CommunityJudgementOptions options;
  EXPECT_TRUE(options.Check());
  options.max_relative_reprojection_error = 0.5;
  EXPECT_FALSE(options.Check());
}

}  // namespace
}  // namespace colmap
