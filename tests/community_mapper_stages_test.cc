// The community mapper's stages end to end: partition, communities and merge
// run as separate commands give the one-process result; a run killed after
// its first community resumes and gives the same result; stages refuse an
// output folder whose plan does not fit, and communities outside the plan;
// the merge joins a community's second model as a community of its own.

#include "colmap_ext/merge/model_join.h"
#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/testing/testing.h"
#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/workflow/community_io.h"
#include "colmap_ext/workflow/community_workspace.h"

#include "colmap/geometry/sim3.h"
#include "colmap/scene/database.h"
#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/types.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

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
    root_ = new std::filesystem::path(
        std::filesystem::path(::testing::TempDir()) / "colmap_ext_tests" /
        "CommunityMapperStages");
    std::filesystem::remove_all(*root_);
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

  static std::filesystem::path ScenePath() { return *root_ / "scene"; }
  static std::filesystem::path DatabasePath() {
    return ScenePath() / "database.db";
  }
  static std::filesystem::path OneGoPath() { return *root_ / "one-go"; }

  // `colmap COMMAND` on the scene's database with the suite's options.
  static std::string Command(const std::string& command,
                             const std::filesystem::path& output_path,
                             const std::filesystem::path& database_path = {}) {
    return std::string(COLMAP_BINARY) + " " + command + " --database_path " +
           ShellQuote(database_path.empty() ? DatabasePath() : database_path) +
           " --image_path " + ShellQuote(ScenePath() / "images") +
           " --output_path " + ShellQuote(output_path) + kOptions;
  }

  // A stage after the partition, with the options of OUT's project.
  static std::string StageCommand(const std::string& command,
                                  const std::filesystem::path& output_path) {
    return std::string(COLMAP_BINARY) + " " + command + " --project_path " +
           ShellQuote(output_path / "project.ini");
  }

  static int NumCommunities(const std::filesystem::path& output_path) {
    return CommunityPlanFromText(ReadTextFile(output_path / "plan.txt"))
        .NumCommunities();
  }

  // `model` aligned to the one-process run's model 0.
  static ModelEvaluation CompareWithOneGo(
      const std::filesystem::path& model_path) {
    Reconstruction model;
    model.Read(model_path);
    Reconstruction one_go;
    one_go.Read(OneGoPath() / "0");
    ModelEvaluation evaluation = EvaluateModel(model, one_go);
    evaluation.num_ground_truth_images =
        static_cast<int>(one_go.NumRegImages());
    return evaluation;
  }

  static ModelEvaluation CompareWithGroundTruth(
      const std::filesystem::path& model_path) {
    Reconstruction model;
    model.Read(model_path);
    Reconstruction ground_truth;
    ground_truth.Read(ScenePath() / "ground_truth");
    return EvaluateModel(model, ground_truth);
  }

  static std::filesystem::path* root_;
  static std::string* one_go_log_;
  static int one_go_status_;
};

std::filesystem::path* CommunityMapperStages::root_ = nullptr;
std::string* CommunityMapperStages::one_go_log_ = nullptr;
int CommunityMapperStages::one_go_status_ = -1;

TEST_F(CommunityMapperStages, SeparateStagesGiveTheOneProcessModel) {
  ASSERT_EQ(one_go_status_, 0) << *one_go_log_;
  // The comparison is worth something: one model of nearly every image.
  const ModelEvaluation one_go =
      CompareWithGroundTruth(OneGoPath() / "0");
  EXPECT_GE(one_go.num_registered_images,
            0.95 * one_go.num_ground_truth_images);
  const std::filesystem::path out = *root_ / "stages";
  std::string log;
  ASSERT_EQ(RunCommand(Command("community_partitioner", out), &log), 0) << log;
  EXPECT_EQ(ReadCommunities(out / "communities.txt"),
            ReadCommunities(OneGoPath() / "communities.txt"));
  EXPECT_FALSE(ExistsDir(out / "communities"));
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
        ExistsFile(out / "communities" / (std::to_string(c) + ".done")));
  }
  ASSERT_EQ(RunCommand(StageCommand("community_merger", out), &log), 0) << log;

  const ModelEvaluation comparison = CompareWithOneGo(out / "0");
  EXPECT_EQ(comparison.num_registered_images,
            comparison.num_ground_truth_images);
  ASSERT_TRUE(comparison.aligned);
  EXPECT_LT(comparison.max_position_error, 1e-6 * comparison.extent);
  EXPECT_EQ(ExistsDir(out / "1"), ExistsDir(OneGoPath() / "1"));

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
  const std::filesystem::path out = *root_ / "killed";
  const std::filesystem::path first_log = *root_ / "killed.log";
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
  // A second run on the same OUT while the first writes it is refused,
  // naming the first.
  std::string second_log;
  EXPECT_NE(RunCommand(Command("community_mapper", out), &second_log), 0);
  EXPECT_NE(second_log.find("Another run is writing " + out.string()),
            std::string::npos)
      << second_log;
  EXPECT_NE(second_log.find("process " + std::to_string(pid) + " on host"),
            std::string::npos)
      << second_log;
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
  EXPECT_FALSE(ExistsDir(out / "0"));

  // The killed run's lock is taken over.
  std::string log;
  ASSERT_EQ(RunCommand(Command("community_mapper", out), &log), 0) << log;
  EXPECT_NE(log.find("Taking over the lock"), std::string::npos) << log;
  EXPECT_FALSE(ExistsFile(out / "lock"));
  // The summary counts the view graph's images on a reused plan too.
  const std::smatch registered = [&log] {
    std::smatch match;
    std::regex_search(
        log, match, std::regex("Registered ([0-9]+) of ([0-9]+) images"));
    return match;
  }();
  ASSERT_EQ(registered.size(), 3) << log;
  EXPECT_GT(std::stoi(registered[2]), 0);
  EXPECT_LE(std::stoi(registered[1]), std::stoi(registered[2]));
  // Its partition's figures are those of a run in one go.
  const auto summary_value = [](const std::filesystem::path& path,
                                const std::string& key) {
    std::smatch match;
    const std::string text = ReadTextFile(path / "summary.txt");
    std::regex_search(text, match, std::regex("\n" + key + " ([^\n]*)"));
    return match.size() == 2 ? match[1].str() : std::string();
  };
  for (const std::string key : {"num_view_graph_images", "max_modularity"}) {
    EXPECT_EQ(summary_value(out, key), summary_value(OneGoPath(), key)) << key;
    EXPECT_NE(summary_value(out, key), "") << key;
  }
  std::string reused = "this plan:";
  for (const int c : finished) {
    reused += " " + std::to_string(c);
  }
  EXPECT_NE(log.find("Reusing the communities reconstructed by an earlier run "
                     "of " +
                     reused + "\n"),
            std::string::npos)
      << log;

  const ModelEvaluation resumed = CompareWithGroundTruth(out / "0");
  const ModelEvaluation one_go =
      CompareWithGroundTruth(OneGoPath() / "0");
  EXPECT_EQ(resumed.num_registered_images, one_go.num_registered_images);
  ASSERT_TRUE(resumed.aligned);
  EXPECT_LT(resumed.median_position_error,
            1.2 * one_go.median_position_error + 1e-4 * one_go.extent);
  // Nothing temporary is left.
  for (const auto& entry :
       std::filesystem::recursive_directory_iterator(out / "communities")) {
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos)
        << entry.path();
  }
}

TEST_F(CommunityMapperStages, StagesRefuseWhatDoesNotFitThePlan) {
  ASSERT_EQ(one_go_status_, 0) << *one_go_log_;
  const std::filesystem::path out = *root_ / "refusals";
  std::string log;

  // No plan yet.
  EXPECT_NE(RunCommand(Command("community_merger", out), &log), 0);
  EXPECT_NE(log.find("plan.txt does not exist"), std::string::npos) << log;
  EXPECT_FALSE(ExistsDir(out));

  ASSERT_EQ(RunCommand(Command("community_partitioner", out), &log), 0) << log;
  const std::string plan = ReadTextFile(out / "plan.txt");

  // Another modularity threshold.
  EXPECT_NE(RunCommand(Command("community_reconstructor", out) +
                           " --community_id 0 "
                           "--CommunityMapper.modularity_threshold 0.4",
                       &log),
            0);
  EXPECT_NE(log.find("CommunityMapper.modularity_threshold is 0.4"),
            std::string::npos)
      << log;
  EXPECT_FALSE(ExistsDir(out / "communities"));

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
  const std::filesystem::path changed = *root_ / "changed.db";
  std::filesystem::copy_file(
      DatabasePath(),
      changed,
      std::filesystem::copy_options::overwrite_existing);
  {
    const std::shared_ptr<Database> database = Database::Open(changed);
    const std::vector<std::pair<image_pair_t, int>> num_inliers =
        database->ReadTwoViewGeometryNumInliers();
    ASSERT_FALSE(num_inliers.empty());
    const auto [image_id1, image_id2] =
        PairIdToImagePair(num_inliers.back().first);
    database->DeleteInlierMatches(image_id1, image_id2);
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
                     (out / "communities").string() + "): " + missing),
            std::string::npos)
      << log;
  EXPECT_FALSE(ExistsDir(out / "0"));
  // Nothing refused changed the plan.
  EXPECT_EQ(ReadTextFile(out / "plan.txt"), plan);
}

// The images the merged models' registrations registered anew, by the log.
int NumNewlyRegistered(const std::string& log) {
  const std::regex pattern("(\\d+) images newly registered");
  int num = 0;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), pattern);
       it != std::sregex_iterator();
       ++it) {
    num += std::stoi((*it)[1]);
  }
  return num;
}

// Where the incremental mapper of a community makes two models (South
// Building: 38 and 28 of a community's 66 images), the second takes part in
// the merge as a community of its own: its images come in with the shape
// the mapper gave them, joined by a similarity, instead of being registered
// one by one into the merged model. Community 0 of the one-process run is
// cut here into two such models across its longest extent, sharing four
// images as the mapper's models may, the second in a frame of its own.
TEST_F(CommunityMapperStages, SecondModelOfACommunityTakesPart) {
  ASSERT_EQ(one_go_status_, 0) << *one_go_log_;
  const CommunityPlan plan =
      CommunityPlanFromText(ReadTextFile(OneGoPath() / "plan.txt"));
  const CommunityWorkspace one_go(OneGoPath());
  Reconstruction community;
  community.Read(one_go.CommunityModelPath(0));
  std::vector<image_t> image_ids = community.RegImageIds();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const image_t image_id : image_ids) {
    mean += community.Image(image_id).ProjectionCenter() / image_ids.size();
  }
  Eigen::MatrixXd centres(image_ids.size(), 3);
  for (size_t i = 0; i < image_ids.size(); ++i) {
    centres.row(i) =
        community.Image(image_ids[i]).ProjectionCenter().transpose() -
        mean.transpose();
  }
  const Eigen::Vector3d axis =
      Eigen::JacobiSVD<Eigen::MatrixXd>(centres, Eigen::ComputeThinV)
          .matrixV()
          .col(0);
  std::sort(image_ids.begin(), image_ids.end(), [&](image_t a, image_t b) {
    return axis.dot(community.Image(a).ProjectionCenter()) <
           axis.dot(community.Image(b).ProjectionCenter());
  });
  const size_t cut = image_ids.size() * 11 / 20;
  const std::unordered_set<image_t> first_ids(image_ids.begin(),
                                              image_ids.begin() + cut + 2);
  const std::unordered_set<image_t> second_ids(image_ids.begin() + cut - 2,
                                               image_ids.end());
  const std::shared_ptr<Reconstruction> first =
      RestrictToImages(first_ids, std::make_shared<Reconstruction>(community));
  const std::shared_ptr<Reconstruction> second =
      RestrictToImages(second_ids, std::make_shared<Reconstruction>(community));
  second->Transform(Sim3d(2.5,
                          Eigen::Quaterniond(Eigen::AngleAxisd(
                              0.6, Eigen::Vector3d(1, 2, 3).normalized())),
                          Eigen::Vector3d(4, -7, 2)));
  int num_second_own = 0;
  for (const std::string& name : plan.communities[0].own_image_names) {
    const Image* image = second->FindImageWithName(name);
    num_second_own += image != nullptr && image->HasPose() &&
                              !first_ids.count(image->ImageId())
                          ? 1
                          : 0;
  }
  ASSERT_GE(num_second_own, 10);

  // `keep_second`: the second model is written beside the first (as the
  // community stage does) or not (a community of one model). Returns the
  // merger's log.
  const auto merge = [&](const std::string& name,
                         const bool keep_second,
                         const std::string& flags = "") {
    const std::filesystem::path out = *root_ / name;
    const CommunityWorkspace workspace(out);
    std::filesystem::remove_all(out);
    std::filesystem::create_directories(workspace.CommunitiesDir());
    for (const char* file : {"plan.txt", "communities.txt"}) {
      std::filesystem::copy_file(OneGoPath() / file, out / file);
    }
    for (int c = 0; c < plan.NumCommunities(); ++c) {
      CommunityRecord record =
          CommunityRecordFromText(ReadTextFile(one_go.CommunityRecordPath(c)));
      // Only community 0's second model, if any, takes part here.
      record.num_other_models = 0;
      if (c == 0) {
        WriteReconstructionAtomically(*first, workspace.CommunityModelPath(0));
        record.num_registered = static_cast<int>(first->NumRegImages());
        record.num_models = 2;
        record.mean_reprojection_error = first->ComputeMeanReprojectionError();
        if (keep_second) {
          WriteReconstructionAtomically(
              *second, workspace.CommunityOtherModelPath(0, 1));
          record.num_other_models = 1;
        }
      } else {
        Reconstruction model;
        model.Read(one_go.CommunityModelPath(c));
        WriteReconstructionAtomically(model, workspace.CommunityModelPath(c));
      }
      WriteTextFileAtomically(CommunityRecordToText(record),
                              workspace.CommunityRecordPath(c));
    }
    std::string log;
    EXPECT_EQ(RunCommand(Command("community_merger", out) + flags, &log), 0)
        << log;
    return log;
  };

  const std::string log = merge("second-model", /*keep_second=*/true);
  // Community 0's second model takes part, as one extra community.
  const std::string summary =
      ReadTextFile(*root_ / "second-model" / "summary.txt");
  EXPECT_NE(summary.find("\nextra_community_origins 0\n"), std::string::npos)
      << summary;
  const ModelEvaluation merged =
      CompareWithGroundTruth(*root_ / "second-model" / "0");
  const ModelEvaluation reference =
      CompareWithGroundTruth(OneGoPath() / "0");
  EXPECT_GE(merged.num_registered_images, reference.num_registered_images);
  EXPECT_FALSE(ExistsDir(*root_ / "second-model" / "1"));
  ASSERT_TRUE(merged.aligned);
  EXPECT_LT(merged.median_position_error,
            1.5 * reference.median_position_error + 1e-4 * reference.extent);
  EXPECT_LT(NumNewlyRegistered(log), num_second_own / 2) << log;

  // Without the second model, its images are registered one by one.
  const std::string without_log = merge("largest-only", /*keep_second=*/false);
  EXPECT_GE(NumNewlyRegistered(without_log), num_second_own / 2) << without_log;
}

}  // namespace
}  // namespace colmap
