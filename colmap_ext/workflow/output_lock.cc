#include "colmap_ext/workflow/output_lock.h"

#include "colmap_ext/workflow/atomic_output.h"

#include "colmap/util/logging.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <unistd.h>

namespace colmap {
namespace {

// Creates `path` holding `text` only if it does not exist. False if it
// exists, or if it cannot be written (then `error` says why and nothing is
// left behind).
bool CreateExclusively(const std::string& path,
                       const std::string& text,
                       std::string* error) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
  if (fd < 0) {
    if (errno != EEXIST) {
      *error = "Cannot create " + path + ": " + std::strerror(errno) + ".";
    }
    return false;
  }
  const bool written =
      ::write(fd, text.data(), text.size()) ==
      static_cast<ssize_t>(text.size());
  ::close(fd);
  if (!written) {
    std::remove(path.c_str());
    *error = "Cannot write " + path + ": check the free space.";
  }
  return written;
}

std::string ReadHolder(const std::string& path) {
  std::ifstream file(path);
  std::string holder;
  std::getline(file, holder);
  return holder;
}

// "process PID on host HOST" of a HOST-PID tag.
std::string HolderText(const std::string& holder) {
  const size_t dash = holder.rfind('-');
  if (dash == std::string::npos) {
    return "an unknown process";
  }
  return "process " + holder.substr(dash + 1) + " on host " +
         holder.substr(0, dash);
}

}  // namespace

std::string OutputLock::Acquire(const std::string& folder) {
  THROW_CHECK(path_.empty()) << "the lock is held already";
  const std::string path =
      (std::filesystem::path(folder) / kOutputLockFileName).string();
  const std::string tag = WriterTag();
  // Twice at most: once more after taking over an ended holder's lock.
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::string error;
    if (CreateExclusively(path, tag + "\n", &error)) {
      path_ = path;
      return "";
    }
    if (!error.empty()) {
      return error;
    }
    const std::string holder = ReadHolder(path);
    if (holder.empty() || !IsEndedWriterOfThisHost(holder)) {
      return "Another run is writing " + folder + ": " + HolderText(holder) +
             " holds " + path +
             ". Wait for it to end, or choose another --output_path. If "
             "that process no longer runs (e.g. it ran on another machine "
             "and was killed), delete " +
             path + " and run again.";
    }
    LOG(WARNING) << "Taking over the lock " << path << " of the run of "
                 << HolderText(holder) << ", which has ended.";
    // Only the file of that ended holder goes: another run may have taken
    // it over in between.
    if (ReadHolder(path) == holder) {
      std::remove(path.c_str());
    }
  }
  return "Could not take the lock " + path + ": another run took it.";
}

void OutputLock::Release() {
  if (path_.empty()) {
    return;
  }
  if (ReadHolder(path_) == WriterTag()) {
    std::remove(path_.c_str());
  }
  path_.clear();
}

}  // namespace colmap
