#include "colmap_ext/testing/testing.h"

#include "colmap_ext/exe/community_mapper_options.h"

#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <sys/wait.h>

namespace colmap {

std::string CreateTestFolder() {
  const testing::TestInfo* test_info = THROW_CHECK_NOTNULL(
      testing::UnitTest::GetInstance()->current_test_info());
  const std::filesystem::path test_dir =
      std::filesystem::path(testing::TempDir()) / "colmap_ext_tests" /
      (std::string(test_info->test_suite_name()) + "." + test_info->name());
  std::filesystem::remove_all(test_dir);
  std::filesystem::create_directories(test_dir);
  return test_dir.string();
}

int RunCommand(const std::string& command, std::string* output) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) {
    return -1;
  }
  std::array<char, 4096> buffer;
  std::string text;
  size_t num_read;
  while ((num_read = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) {
    text.append(buffer.data(), num_read);
  }
  const int status = pclose(pipe);
  if (output != nullptr) {
    *output = std::move(text);
  }
  if (status == -1 || !WIFEXITED(status)) {
    return -1;
  }
  return WEXITSTATUS(status);
}

std::string ShellQuote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) {
    if (c == '\'') {
      quoted += "'\\''";
    } else {
      quoted += c;
    }
  }
  return quoted + "'";
}

std::unordered_map<std::string, int> ReadCommunities(const std::string& path) {
  std::ifstream file(path);
  THROW_CHECK_FILE_OPEN(file, path);
  std::unordered_map<std::string, int> communities;
  std::string line;
  while (std::getline(file, line)) {
    StringTrim(&line);
    if (line.empty() || line[0] == '#') {
      continue;
    }
    const size_t space = line.find_last_of(' ');
    THROW_CHECK_NE(space, std::string::npos) << "Malformed line: " << line;
    const std::string name = line.substr(0, space);
    const int community = std::stoi(line.substr(space + 1));
    THROW_CHECK(communities.emplace(name, community).second)
        << "Image listed twice: " << name;
  }
  return communities;
}

void SynthesizeTwoLandmarks(const bool single_camera,
                            SyntheticScene* scene,
                            std::set<image_t>* other_images,
                            std::set<image_t>* landmark1_images) {
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 20;
  options.num_images_per_link = 10;
  options.close_loop = false;
  options.keypoint_noise = 0;
  options.single_camera = single_camera;
  options.seed = 7;
  SynthesizeCommunityScene(options, scene, /*database=*/nullptr);
  for (const auto& image_and_cluster : scene->image_cluster) {
    (image_and_cluster.second == 1 ? landmark1_images : other_images)
        ->insert(image_and_cluster.first);
  }
}

Reconstruction CommunityModel(const Reconstruction& ground_truth,
                              const std::set<image_t>& image_ids,
                              const Sim3d& model_from_world) {
  Reconstruction model = ground_truth;
  for (const frame_t frame_id : ground_truth.RegFrameIds()) {
    bool keep = false;
    for (const data_t& data_id : ground_truth.Frame(frame_id).ImageIds()) {
      keep = keep || image_ids.count(static_cast<image_t>(data_id.id)) > 0;
    }
    if (!keep) {
      // Deletes the points left with fewer than two observations.
      model.DeRegisterFrame(frame_id);
    }
  }
  model.Transform(model_from_world);
  return model;
}

void MoveImagesWithTheirPoints(const std::set<image_t>& image_ids,
                               const Eigen::Vector3d& offset,
                               Reconstruction* model) {
  for (const image_t image_id : image_ids) {
    Frame& frame = model->Frame(model->Image(image_id).FrameId());
    Rigid3d rig_from_world = frame.RigFromWorld();
    // Centre c + offset: t' = t - R offset.
    rig_from_world.translation() -= rig_from_world.rotation() * offset;
    frame.SetRigFromWorld(rig_from_world);
  }
  for (const point3D_t point3D_id : model->Point3DIds()) {
    const Point3D point3D = model->Point3D(point3D_id);
    Track moved;
    Track stays;
    for (const TrackElement& element : point3D.track.Elements()) {
      (image_ids.count(element.image_id) ? moved : stays).AddElement(element);
    }
    if (moved.Length() == 0) {
      continue;
    }
    model->DeletePoint3D(point3D_id);
    if (moved.Length() >= 2) {
      model->AddPoint3D(point3D.xyz + offset, moved);
    }
    if (stays.Length() >= 2) {
      model->AddPoint3D(point3D.xyz, stays);
    }
  }
}

std::string CommunityMapperOptionsMarkdown() {
  CommunityMapperCommandOptions defaults;
  const std::vector<CommunityMapperOption> table =
      CommunityMapperOptionTable(&defaults);
  std::string text =
      "# `colmap community_mapper` options\n\n"
      "Generated from the option table "
      "(`colmap_ext/exe/community_mapper_options.cc`); "
      "`colmap community_mapper -h` lists the same. Every option is "
      "`--CommunityMapper.NAME VALUE`. The command also takes COLMAP's "
      "`--Mapper.*` options (every community's incremental mapper and the "
      "merge's registration, triangulation and bundle adjustment; "
      "`--Mapper.min_num_matches` is the view graph's minimum of verified "
      "inlier matches per edge), `--image_list_path` and `--project_path`.\n"
      "\n"
      "Options marked *plan* shape the partition and the communities' "
      "models: the plan records them, and a later stage or a resumed run "
      "given another value is refused.\n";
  for (const bool advanced : {false, true}) {
    text += advanced ? "\n## Advanced options, by stage\n\n"
                     : "\n## Options users set\n\n";
    text += "| option | default | meaning |\n| --- | --- | --- |\n";
    for (const CommunityMapperOption& option : table) {
      if (option.advanced == advanced) {
        text += "| `" + option.name + "` | " + option.ValueToText() +
                " | " + (option.shapes_plan ? "*plan*: " : "") + option.help +
                " |\n";
      }
    }
  }
  return text;
}

}  // namespace colmap
