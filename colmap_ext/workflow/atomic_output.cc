#include "colmap_ext/workflow/atomic_output.h"

#include "colmap/util/file.h"
#include "colmap/util/logging.h"

#include <cerrno>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <vector>

#include <unistd.h>

namespace colmap {

std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0) {
    return "unknown";
  }
  return name;
}

std::string WriterTag() {
  return HostName() + "-" + std::to_string(::getpid());
}

namespace {

std::string TemporaryPath(const std::string& path) {
  return path + ".tmp-" + WriterTag();
}

std::string ParentFolder(const std::string& path) {
  const std::filesystem::path parent =
      std::filesystem::path(path).parent_path();
  return parent.empty() ? "." : parent.string();
}

}  // namespace

bool IsEndedWriterOfThisHost(const std::string& tag) {
  const size_t dash = tag.rfind('-');
  if (dash == std::string::npos || tag.substr(0, dash) != HostName()) {
    return false;
  }
  const std::string pid_text = tag.substr(dash + 1);
  if (pid_text.empty() ||
      pid_text.find_first_not_of("0123456789") != std::string::npos) {
    return false;
  }
  const pid_t pid = static_cast<pid_t>(std::stol(pid_text));
  if (pid == ::getpid()) {
    return false;
  }
  if (::kill(pid, 0) != 0) {
    return errno == ESRCH;
  }
  // A killed process that nobody reaped yet (a zombie) has ended too.
  std::ifstream stat("/proc/" + pid_text + "/stat");
  std::string line;
  if (!std::getline(stat, line)) {
    return false;
  }
  const size_t name_end = line.rfind(')');
  return name_end != std::string::npos && name_end + 2 < line.size() &&
         (line[name_end + 2] == 'Z' || line[name_end + 2] == 'X');
}

int RemoveLeftoversOfEndedWriters(const std::string& folder) {
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) {
    return 0;
  }
  std::vector<std::filesystem::path> leftovers;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    for (const std::string marker : {".tmp-", ".old-"}) {
      const size_t position = name.rfind(marker);
      if (position == std::string::npos || position == 0 ||
          !IsEndedWriterOfThisHost(name.substr(position + marker.size()))) {
        continue;
      }
      // A previous output moved aside is the only copy where the writer
      // ended before its new output took the name: it stays then.
      if (marker == ".old-" &&
          !std::filesystem::exists(std::filesystem::path(folder) /
                                   name.substr(0, position))) {
        continue;
      }
      leftovers.push_back(entry.path());
    }
  }
  for (const auto& leftover : leftovers) {
    std::filesystem::remove_all(leftover, error);
  }
  return static_cast<int>(leftovers.size());
}

void WriteReconstructionAtomically(const Reconstruction& reconstruction,
                                   const std::string& path) {
  const std::string temporary = TemporaryPath(path);
  std::filesystem::remove_all(temporary);
  try {
    std::filesystem::create_directories(temporary);
    reconstruction.WriteBinary(temporary);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove_all(temporary, ignored);
    throw;
  }

  // A folder cannot be renamed over a non-empty one: move the old one aside
  // first, then drop it.
  const std::string previous = path + ".old-" + WriterTag();
  const bool had_previous = std::filesystem::exists(path);
  if (had_previous) {
    std::filesystem::rename(path, previous);
  }
  std::filesystem::rename(temporary, path);
  if (had_previous) {
    std::filesystem::remove_all(previous);
  }
  RemoveLeftoversOfEndedWriters(ParentFolder(path));
}

void WriteTextFileAtomically(const std::string& text, const std::string& path) {
  const std::string temporary = TemporaryPath(path);
  std::ofstream file(temporary, std::ios::trunc);
  THROW_CHECK_FILE_OPEN(file, temporary);
  file << text;
  file.close();
  THROW_CHECK(file.good()) << "Could not write " << temporary;
  std::filesystem::rename(temporary, path);
  RemoveLeftoversOfEndedWriters(ParentFolder(path));
}

bool IsModelDir(const std::string& path) {
  // Rigs and frames (rigs.bin, frames.bin) are optional: COLMAP reads a
  // model without them with one rig per camera and one frame per image.
  for (const std::string name : {"cameras", "images", "points3D"}) {
    if (ExistsFile(std::filesystem::path(path) / (name + ".bin")) ||
        ExistsFile(std::filesystem::path(path) / (name + ".txt"))) {
      return true;
    }
  }
  return false;
}

}  // namespace colmap
