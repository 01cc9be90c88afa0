#include "colmap_ext/workflow/community_workspace.h"

#include "colmap_ext/workflow/atomic_output.h"

#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <type_traits>

namespace colmap {
namespace {

// 64-bit FNV-1a.
class Fingerprint {
 public:
  void Add(const std::string& text) {
    for (const char c : text) {
      hash_ ^= static_cast<unsigned char>(c);
      hash_ *= 1099511628211ULL;
    }
    // A separator, so that ("ab", "c") and ("a", "bc") differ.
    hash_ ^= 0xff;
    hash_ *= 1099511628211ULL;
  }
  std::string Hex() const {
    return StringPrintf("%016llx", static_cast<unsigned long long>(hash_));
  }

 private:
  uint64_t hash_ = 14695981039346656037ULL;
};

// "key value" lines, the value being the rest of the line.
std::map<std::string, std::string> ReadKeyValues(const std::string& text) {
  std::map<std::string, std::string> values;
  std::istringstream stream(text);
  std::string line;
  while (std::getline(stream, line)) {
    if (line.empty() || line[0] == '#') {
      continue;
    }
    const size_t space = line.find(' ');
    values[line.substr(0, space)] =
        space == std::string::npos ? "" : line.substr(space + 1);
  }
  return values;
}

const std::string& Value(const std::map<std::string, std::string>& values,
                         const std::string& key) {
  const auto it = values.find(key);
  if (it == values.end()) {
    throw std::invalid_argument("it has no '" + key + "' line");
  }
  return it->second;
}

// The value of `key` as a T (int or double).
template <typename T>
T NumberValue(const std::map<std::string, std::string>& values,
              const std::string& key) {
  try {
    const std::string& value = Value(values, key);
    return std::is_same_v<T, int> ? std::stoi(value) : std::stod(value);
  } catch (const std::logic_error&) {
    throw std::invalid_argument("its '" + key + "' is not a number");
  }
}

// The items sorted by `key` (a member or a getter), so that the fingerprint
// does not depend on the order in which the database returns them.
template <typename T, typename Key>
std::vector<T> SortedBy(std::vector<T> items, const Key key) {
  std::sort(items.begin(), items.end(), [key](const T& a, const T& b) {
    return std::invoke(key, a) < std::invoke(key, b);
  });
  return items;
}

std::map<std::string, std::string> OptionLines(const std::string& options) {
  std::map<std::string, std::string> values;
  std::istringstream stream(options);
  std::string line;
  while (std::getline(stream, line)) {
    const size_t equals = line.find('=');
    if (equals != std::string::npos) {
      values[line.substr(0, equals)] = line.substr(equals + 1);
    }
  }
  return values;
}

}  // namespace

CommunityWorkspace::CommunityWorkspace(std::string output_path)
    : output_path_(std::move(output_path)) {}

std::string CommunityWorkspace::Join(const std::string& name) const {
  return (std::filesystem::path(output_path_) / name).string();
}

std::vector<std::string> CommunityWorkspace::MergedModelPaths() const {
  std::vector<std::string> paths;
  for (int i = 0; ExistsDir(MergedModelPath(i)); ++i) {
    if (IsModelDir(MergedModelPath(i))) {
      paths.push_back(MergedModelPath(i));
    }
  }
  return paths;
}

bool CommunityWorkspace::HasResults() const {
  return ExistsFile(PlanPath()) || ExistsFile(CommunitiesPath()) ||
         ExistsDir(CommunitiesDir()) || !MergedModelPaths().empty();
}

std::string CommunityWorkspace::CreateOutputFolder() const {
  if (output_path_.empty()) {
    return "--output_path is empty.";
  }
  if (ExistsPath(output_path_) && !ExistsDir(output_path_)) {
    return "--output_path " + output_path_ +
           " is a file, not a folder: choose a folder for the models.";
  }
  std::error_code error;
  std::filesystem::create_directories(output_path_, error);
  if (error) {
    return "Cannot create --output_path " + output_path_ + ": " +
           error.message() + ".";
  }
  const std::filesystem::path probe =
      std::filesystem::path(output_path_) / ".write-test";
  {
    std::ofstream file(probe);
    if (!file.is_open() || !(file << "x")) {
      return "--output_path " + output_path_ +
             " is not writable: choose a folder you can write to.";
    }
  }
  std::filesystem::remove(probe, error);
  return "";
}

void CommunityWorkspace::RemoveCommunity(const int community_id) const {
  std::error_code error;
  std::filesystem::remove(CommunityRecordPath(community_id), error);
  std::filesystem::remove_all(CommunityModelPath(community_id), error);
  for (int index = 1; ExistsDir(CommunityOtherModelPath(community_id, index));
       ++index) {
    std::filesystem::remove_all(CommunityOtherModelPath(community_id, index),
                                error);
  }
}

void CommunityWorkspace::WriteMergedModels(
    const std::vector<std::shared_ptr<const Reconstruction>>& models) const {
  for (size_t i = 0; i < models.size(); ++i) {
    WriteReconstructionAtomically(*models[i], MergedModelPath(i));
  }
  // Models of an earlier run beyond the new ones would mix with them.
  std::error_code error;
  for (size_t i = models.size(); ExistsDir(MergedModelPath(i)); ++i) {
    std::filesystem::remove_all(MergedModelPath(i), error);
  }
}

void CommunityWorkspace::RemoveResults() const {
  std::error_code error;
  std::filesystem::remove(PlanPath(), error);
  std::filesystem::remove(CommunitiesPath(), error);
  std::filesystem::remove(CommunitiesPlyPath(), error);
  std::filesystem::remove(SummaryPath(), error);
  std::filesystem::remove_all(CommunitiesDir(), error);
  for (int i = 0; ExistsDir(MergedModelPath(i)); ++i) {
    std::filesystem::remove_all(MergedModelPath(i), error);
  }
}

std::string CommunityPlanToText(const CommunityPlan& plan) {
  std::ostringstream text;
  text << "# Plan of a community_mapper run, written by its partition: what "
          "its community\n# and merge stages read and must agree on. Do not "
          "edit.\n";
  text << "database_path " << plan.database_path << "\n";
  text << "database_fingerprint " << plan.database_fingerprint << "\n";
  text << "options\n" << plan.options;
  if (!plan.options.empty() && plan.options.back() != '\n') {
    text << "\n";
  }
  text << "end_options\n";
  text << "max_modularity " << StringPrintf("%.6f", plan.max_modularity)
       << "\n";
  text << "num_view_graph_components " << plan.num_view_graph_components
       << "\n";
  text << "num_communities " << plan.communities.size() << "\n";
  for (size_t c = 0; c < plan.communities.size(); ++c) {
    for (const std::string& name : plan.communities[c].own_image_names) {
      text << "image " << c << " own " << name << "\n";
    }
    for (const std::string& name : plan.communities[c].borrowed_image_names) {
      text << "image " << c << " borrowed " << name << "\n";
    }
  }
  return text.str();
}

CommunityPlan CommunityPlanFromText(const std::string& text) {
  CommunityPlan plan;
  std::istringstream stream(text);
  std::string line;
  const auto check_line = [&line](const bool well_formed) {
    if (!well_formed) {
      throw std::invalid_argument("malformed line '" + line + "'");
    }
  };
  bool in_options = false;
  bool has_num_communities = false;
  bool has_options = false;
  while (std::getline(stream, line)) {
    if (in_options) {
      if (line == "end_options") {
        in_options = false;
      } else {
        plan.options += line + "\n";
      }
      continue;
    }
    if (line.empty() || line[0] == '#') {
      continue;
    }
    std::istringstream fields(line);
    std::string key;
    fields >> key;
    if (key == "database_path") {
      plan.database_path = line.substr(key.size() + 1);
    } else if (key == "database_fingerprint") {
      fields >> plan.database_fingerprint;
    } else if (key == "options") {
      in_options = true;
      has_options = true;
    } else if (key == "max_modularity") {
      fields >> plan.max_modularity;
      check_line(!fields.fail());
    } else if (key == "num_view_graph_components") {
      fields >> plan.num_view_graph_components;
      check_line(!fields.fail() && plan.num_view_graph_components >= 0);
    } else if (key == "num_communities") {
      int num_communities = -1;
      fields >> num_communities;
      check_line(!fields.fail() && num_communities >= 0);
      plan.communities.resize(num_communities);
      has_num_communities = true;
    } else if (key == "image") {
      int community = -1;
      std::string kind;
      fields >> community >> kind;
      std::string name;
      std::getline(fields, name);
      check_line(!fields.fail() && has_num_communities && community >= 0 &&
                 community < plan.NumCommunities() && name.size() >= 2 &&
                 (kind == "own" || kind == "borrowed"));
      name = name.substr(1);
      (kind == "own" ? plan.communities[community].own_image_names
                     : plan.communities[community].borrowed_image_names)
          .push_back(name);
    } else {
      throw std::invalid_argument("unknown line '" + line + "'");
    }
  }
  if (in_options || !has_options || !has_num_communities ||
      plan.database_fingerprint.empty()) {
    throw std::invalid_argument("it is incomplete");
  }
  return plan;
}

std::string TextsFingerprint(const std::vector<std::string>& texts) {
  Fingerprint fingerprint;
  for (const std::string& text : texts) {
    fingerprint.Add(text);
  }
  return fingerprint.Hex();
}

std::string DatabaseFingerprint(const Database& database) {
  Fingerprint fingerprint;
  for (const Camera& camera :
       SortedBy(database.ReadAllCameras(), &Camera::camera_id)) {
    std::string params;
    for (const double param : camera.params) {
      params += StringPrintf(" %.17g", param);
    }
    fingerprint.Add(StringPrintf("camera %d %d %d %d%s",
                                 static_cast<int>(camera.camera_id),
                                 static_cast<int>(camera.model_id),
                                 static_cast<int>(camera.width),
                                 static_cast<int>(camera.height),
                                 params.c_str()));
  }
  for (const Image& image :
       SortedBy(database.ReadAllImages(), &Image::ImageId)) {
    fingerprint.Add(StringPrintf("image %d %d ",
                                 static_cast<int>(image.ImageId()),
                                 static_cast<int>(image.CameraId())) +
                    image.Name());
  }
  // Rigs and frames decide which images the mappers pose together. A
  // database without them (the mappers then take one rig per camera and one
  // frame per image) adds nothing.
  for (const Rig& rig : SortedBy(database.ReadAllRigs(), &Rig::RigId)) {
    std::string sensors = StringPrintf(" %d:%d",
                                       static_cast<int>(rig.RefSensorId().type),
                                       static_cast<int>(rig.RefSensorId().id));
    for (const auto& [sensor_id, sensor_from_rig] : rig.NonRefSensors()) {
      sensors += StringPrintf(" %d:%d",
                              static_cast<int>(sensor_id.type),
                              static_cast<int>(sensor_id.id));
      if (sensor_from_rig.has_value()) {
        for (int i = 0; i < sensor_from_rig->params.size(); ++i) {
          sensors += StringPrintf(" %.17g", sensor_from_rig->params(i));
        }
      }
    }
    fingerprint.Add(StringPrintf("rig %d", static_cast<int>(rig.RigId())) +
                    sensors);
  }
  for (const Frame& frame :
       SortedBy(database.ReadAllFrames(), &Frame::FrameId)) {
    std::string data = StringPrintf("frame %d %d",
                                    static_cast<int>(frame.FrameId()),
                                    static_cast<int>(frame.RigId()));
    for (const data_t& data_id : frame.DataIds()) {
      data += StringPrintf(" %d:%d:%d",
                           static_cast<int>(data_id.sensor_id.type),
                           static_cast<int>(data_id.sensor_id.id),
                           static_cast<int>(data_id.id));
    }
    fingerprint.Add(data);
  }
  std::vector<std::pair<std::pair<image_t, image_t>, int>> pairs;
  for (const auto& [pair_id, num_inliers] :
       database.ReadTwoViewGeometryNumInliers()) {
    pairs.emplace_back(PairIdToImagePair(pair_id), num_inliers);
  }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& pair : pairs) {
    fingerprint.Add(StringPrintf("pair %d %d %d",
                                 static_cast<int>(pair.first.first),
                                 static_cast<int>(pair.first.second),
                                 pair.second));
  }
  return fingerprint.Hex();
}

std::string PlanMismatch(const CommunityPlan& plan,
                         const std::string& database_fingerprint,
                         const std::string& options) {
  if (plan.database_fingerprint != database_fingerprint) {
    return "the database " + plan.database_path +
           " of the plan had other images or verified pairs (fingerprint " +
           plan.database_fingerprint + ", now " + database_fingerprint + ")";
  }
  const std::map<std::string, std::string> planned = OptionLines(plan.options);
  const std::map<std::string, std::string> given = OptionLines(options);
  for (const auto& [key, value] : given) {
    const auto it = planned.find(key);
    if (it == planned.end()) {
      return "the plan has no option " + key;
    }
    if (it->second != value) {
      return "--" + key + " is " + value + ", the plan's is " + it->second;
    }
  }
  for (const auto& key_and_value : planned) {
    if (given.count(key_and_value.first) == 0) {
      return "the plan has option " + key_and_value.first +
             ", which this run does not";
    }
  }
  return "";
}

std::string CommunityRecordToText(const CommunityRecord& record) {
  std::ostringstream text;
  text << "# A community of a community_mapper run, reconstructed (its "
          "model is beside).\n";
  text << "community " << record.community_id << "\n";
  text << "num_images " << record.num_images << "\n";
  text << "num_registered " << record.num_registered << "\n";
  text << "num_points " << record.num_points << "\n";
  text << "num_models " << record.num_models << "\n";
  text << "num_other_models " << record.num_other_models << "\n";
  text << StringPrintf("mean_reprojection_error %.6f\n",
                       record.mean_reprojection_error);
  text << StringPrintf("seconds %.3f\n", record.seconds);
  text << "database_fingerprint " << record.database_fingerprint << "\n";
  return text.str();
}

std::string DescribeCommunityRecord(const CommunityRecord& record) {
  if (record.num_registered == 0) {
    return StringPrintf(
        "Community %d (%d images) could not be reconstructed; it takes no "
        "part in the merge.",
        record.community_id,
        record.num_images);
  }
  return StringPrintf(
      "Community %d done: %d of %d images registered%s, %d points (%.1fs)",
      record.community_id,
      record.num_registered,
      record.num_images,
      record.num_models > 1
          ? StringPrintf(" in the largest of %d models (%d kept beside it)",
                         record.num_models,
                         record.num_other_models)
                .c_str()
          : "",
      record.num_points,
      record.seconds);
}

CommunityRecord CommunityRecordFromText(const std::string& text) {
  const std::map<std::string, std::string> values = ReadKeyValues(text);
  CommunityRecord record;
  record.community_id = NumberValue<int>(values, "community");
  record.num_images = NumberValue<int>(values, "num_images");
  record.num_registered = NumberValue<int>(values, "num_registered");
  record.num_points = NumberValue<int>(values, "num_points");
  record.num_models = NumberValue<int>(values, "num_models");
  // The line is optional: a record without it has no other model.
  record.num_other_models = values.count("num_other_models") > 0
                                ? NumberValue<int>(values, "num_other_models")
                                : 0;
  record.mean_reprojection_error =
      NumberValue<double>(values, "mean_reprojection_error");
  record.seconds = NumberValue<double>(values, "seconds");
  record.database_fingerprint = Value(values, "database_fingerprint");
  return record;
}

std::string ReadTextFile(const std::string& path) {
  std::ifstream file(path);
  THROW_CHECK_FILE_OPEN(file, path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

}  // namespace colmap
