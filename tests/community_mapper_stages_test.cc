// The community mapper's stages end to end: partition, communities and merge
// run as separate commands give the one-process result; a run killed after
// its first community resumes and gives the same result; stages refuse an
// output folder whose plan does not fit, and communities outside the plan.

#include "colmap_ext/scene/community_io.h"
#include "colmap_ext/scene/community_workspace.h"
#include "colmap_ext/scene/model_evaluation.h"
#include "colmap_ext/util/testing.h"

#include "colmap/scene/database.h"
#include "colmap/util/misc.h"

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>

namespace colmap {
namespace {

// One thread per community mapper: each community's model is then the same
// whichever process or thread reconstructs it.
constexpr char kOptions[] = " --Mapper.num_threads 1";

class CommunityMapperStages : public ::testing::Test {
 protected:
  // Three landmark clusters of 24 images joined in a loop by walkways of 20
  // (132 images), reconstructed once in one process.
  static void SetUpTestSuite() {
    root_ = new std::string(JoinPaths(
        ::testing::TempDir(), "colmap_ext_tests", "CommunityMapperStages"));
    boost::filesystem::remove_all(*root_);
    std::string output;
    THROW_CHECK_EQ(
        RunCommand(std::string(SCENE_GENERATOR_BINARY) + " --output_path " +
                       ShellQuote(ScenePath()) +
                       " --num_clusters 3 --num_images_per_cluster 24 "
                       "--num_images_per_link 20 --seed 17",
                   &output),
        0)
        << output;
    one_go_log_ = new std::string;
    one_go_status_ =
        RunCommand(Command("community_mapper", OneGoPath()), one_go_log_);
  }

  static void TearDownTestSuite() {
    delete root_;
    delete one_go_log_;
  }

  static std::string ScenePath() { return JoinPaths(*root_, "scene"); }
  static std::string DatabasePath() {
    return JoinPaths(ScenePath(), "database.db");
  }
  static std::string OneGoPath() { return JoinPaths(*root_, "one-go"); }

  // `colmap COMMAND` on the scene's database with the suite's options.
  static std::string Command(const std::string& command,
                             const std::string& output_path,
                             const std::string& database_path = "") {
    return std::string(COLMAP_BINARY) + " " + command + " --database_path " +
           ShellQuote(database_path.empty() ? DatabasePath() : database_path) +
           " --image_path " + ShellQuote(JoinPaths(ScenePath(), "images")) +
           " --output_path " + ShellQuote(output_path) + kOptions;
  }

  // A stage after the partition, with the options of OUT's project.
  static std::string StageCommand(const std::string& command,
                                  const std::string& output_path) {
    return std::string(COLMAP_BINARY) + " " + command + " --project_path " +
           ShellQuote(JoinPaths(output_path, "project.ini"));
  }

  static int NumCommunities(const std::string& output_path) {
    return CommunityPlanFromText(
               ReadTextFile(JoinPaths(output_path, "plan.txt")))
        .NumCommunities();
  }

  // `model` aligned to the one-process run's model 0.
  static ModelEvaluation CompareWithOneGo(const std::string& model_path) {
    Reconstruction model;
    model.Read(model_path);
    Reconstruction one_go;
    one_go.Read(JoinPaths(OneGoPath(), "0"));
    ModelEvaluation evaluation = EvaluateModel(model, one_go);
    evaluation.num_ground_truth_images =
        static_cast<int>(one_go.NumRegImages());
    return evaluation;
  }

  static ModelEvaluation CompareWithGroundTruth(const std::string& model_path) {
    Reconstruction model;
    model.Read(model_path);
    Reconstruction ground_truth;
    ground_truth.Read(JoinPaths(ScenePath(), "ground_truth"));
    return EvaluateModel(model, ground_truth);
  }

  static std::string* root_;
  static std::string* one_go_log_;
  static int one_go_status_;
};

std::string* CommunityMapperStages::root_ = nullptr;
std::string* CommunityMapperStages::one_go_log_ = nullptr;
int CommunityMapperStages::one_go_status_ = -1;

TEST_F(CommunityMapperStages, SeparateStagesGiveTheOneProcessModel) {
  ASSERT_EQ(one_go_status_, 0) << *one_go_log_;
  // The comparison is worth something: one model of nearly every image.
  const ModelEvaluation one_go =
      CompareWithGroundTruth(JoinPaths(OneGoPath(), "0"));
  EXPECT_GE(one_go.num_registered_images,
            0.95 * one_go.num_ground_truth_images);
  const std::string out = JoinPaths(*root_, "stages");
  std::string log;
  ASSERT_EQ(RunCommand(Command("community_partitioner", out), &log), 0) << log;
  EXPECT_EQ(ReadCommunities(JoinPaths(out, "communities.txt")),
            ReadCommunities(JoinPaths(OneGoPath(), "communities.txt")));
  EXPECT_FALSE(ExistsDir(JoinPaths(out, "communities")));
  const int num_communities = NumCommunities(out);
  ASSERT_GE(num_communities, 2);
  // In reverse order, each as its own process, as a scheduler might.
  for (int c = num_communities - 1; c >= 0; --c) {
    ASSERT_EQ(RunCommand(StageCommand("community_reconstructor", out) +
                             " --community_id " + std::to_string(c),
                         &log),
              0)
        << log;
    EXPECT_TRUE(
        ExistsFile(JoinPaths(out, "communities", std::to_string(c) + ".done")));
  }
  ASSERT_EQ(RunCommand(StageCommand("community_merger", out), &log), 0) << log;

  const ModelEvaluation comparison = CompareWithOneGo(JoinPaths(out, "0"));
  EXPECT_EQ(comparison.num_registered_images,
            comparison.num_ground_truth_images);
  ASSERT_TRUE(comparison.aligned);
  EXPECT_LT(comparison.max_position_error, 1e-6 * comparison.extent);
  EXPECT_EQ(ExistsDir(JoinPaths(out, "1")),
            ExistsDir(JoinPaths(OneGoPath(), "1")));

  // A rerun community stage reuses its record.
  ASSERT_EQ(RunCommand(StageCommand("community_reconstructor", out) +
                           " --community_id 0",
                       &log),
            0)
      << log;
  EXPECT_NE(log.find("it is reused"), std::string::npos) << log;
}

TEST_F(CommunityMapperStages, KilledRunResumesWithTheSameResult) {
  ASSERT_EQ(one_go_status_, 0) << *one_go_log_;
  const std::string out = JoinPaths(*root_, "killed");
  const std::string first_log = JoinPaths(*root_, "killed.log");
  // Started in the background and killed (SIGKILL) once its first community
  // has its record.
  std::string pid_text;
  ASSERT_EQ(RunCommand(Command("community_mapper", out) + " > " +
                           ShellQuote(first_log) + " 2>&1 & echo $!",
                       &pid_text),
            0);
  const int pid = std::stoi(pid_text);
  const CommunityWorkspace workspace(out);
  std::vector<int> finished;
  for (int i = 0; i < 6000 && finished.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    for (int c = 0; c < 10; ++c) {
      if (ExistsFile(workspace.CommunityRecordPath(c))) {
        finished.push_back(c);
      }
    }
  }
  RunCommand("kill -9 " + std::to_string(pid));
  ASSERT_FALSE(finished.empty()) << ReadTextFile(first_log);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  // Records written between the check and the kill count too.
  finished.clear();
  for (int c = 0; c < 10; ++c) {
    if (ExistsFile(workspace.CommunityRecordPath(c))) {
      finished.push_back(c);
    }
  }
  ASSERT_LT(static_cast<int>(finished.size()), NumCommunities(out))
      << "the run finished every community before it was killed";
  EXPECT_FALSE(ExistsDir(JoinPaths(out, "0")));

  std::string log;
  ASSERT_EQ(RunCommand(Command("community_mapper", out), &log), 0) << log;
  std::string reused = "this plan:";
  for (const int c : finished) {
    reused += " " + std::to_string(c);
  }
  EXPECT_NE(log.find("Reusing the communities reconstructed by an earlier run "
                     "of " +
                     reused + "\n"),
            std::string::npos)
      << log;

  const ModelEvaluation resumed = CompareWithGroundTruth(JoinPaths(out, "0"));
  const ModelEvaluation one_go =
      CompareWithGroundTruth(JoinPaths(OneGoPath(), "0"));
  EXPECT_EQ(resumed.num_registered_images, one_go.num_registered_images);
  ASSERT_TRUE(resumed.aligned);
  EXPECT_LT(resumed.median_position_error,
            1.2 * one_go.median_position_error + 1e-4 * one_go.extent);
  // Nothing temporary is left.
  for (const auto& entry : boost::filesystem::recursive_directory_iterator(
           JoinPaths(out, "communities"))) {
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos)
        << entry.path();
  }
}

TEST_F(CommunityMapperStages, StagesRefuseWhatDoesNotFitThePlan) {
  ASSERT_EQ(one_go_status_, 0) << *one_go_log_;
  const std::string out = JoinPaths(*root_, "refusals");
  std::string log;

  // No plan yet.
  EXPECT_NE(RunCommand(Command("community_merger", out), &log), 0);
  EXPECT_NE(log.find("plan.txt does not exist"), std::string::npos) << log;
  EXPECT_FALSE(ExistsDir(out));

  ASSERT_EQ(RunCommand(Command("community_partitioner", out), &log), 0) << log;
  const std::string plan = ReadTextFile(JoinPaths(out, "plan.txt"));

  // Another modularity threshold.
  EXPECT_NE(RunCommand(Command("community_reconstructor", out) +
                           " --community_id 0 "
                           "--CommunityMapper.modularity_threshold 0.4",
                       &log),
            0);
  EXPECT_NE(log.find("CommunityMapper.modularity_threshold is 0.4"),
            std::string::npos)
      << log;
  EXPECT_FALSE(ExistsDir(JoinPaths(out, "communities")));

  // A community outside the plan.
  EXPECT_NE(RunCommand(StageCommand("community_reconstructor", out) +
                           " --community_id 99",
                       &log),
            0);
  EXPECT_NE(log.find("Community 99 is not in the plan"), std::string::npos)
      << log;
  EXPECT_NE(RunCommand(StageCommand("community_reconstructor", out), &log), 0);
  EXPECT_NE(log.find("--community_id is missing"), std::string::npos) << log;

  // A changed database: one verified pair fewer.
  const std::string changed = JoinPaths(*root_, "changed.db");
  boost::filesystem::copy_file(
      DatabasePath(),
      changed,
      boost::filesystem::copy_options::overwrite_existing);
  {
    Database database(changed);
    std::vector<std::pair<image_t, image_t>> image_pairs;
    std::vector<int> num_inliers;
    database.ReadTwoViewGeometryNumInliers(&image_pairs, &num_inliers);
    ASSERT_FALSE(image_pairs.empty());
    database.DeleteInlierMatches(image_pairs.back().first,
                                 image_pairs.back().second);
  }
  EXPECT_NE(RunCommand(Command("community_mapper", out, changed), &log), 0);
  EXPECT_NE(log.find("other images or verified pairs"), std::string::npos)
      << log;

  // The merge names the communities without a record.
  ASSERT_EQ(RunCommand(StageCommand("community_reconstructor", out) +
                           " --community_id 0",
                       &log),
            0)
      << log;
  EXPECT_NE(RunCommand(StageCommand("community_merger", out), &log), 0);
  const int num_communities = NumCommunities(out);
  std::string missing;
  for (int c = 1; c < num_communities; ++c) {
    missing += (missing.empty() ? "" : ", ") + std::to_string(c);
  }
  EXPECT_NE(log.find("have not been reconstructed (no record in " +
                     JoinPaths(out, "communities") + "): " + missing),
            std::string::npos)
      << log;
  EXPECT_FALSE(ExistsDir(JoinPaths(out, "0")));
  // Nothing refused changed the plan.
  EXPECT_EQ(ReadTextFile(JoinPaths(out, "plan.txt")), plan);
}

}  // namespace
}  // namespace colmap
