#include "colmap_ext/util/atomic_output.h"

#include "colmap/util/logging.h"
#include "colmap/util/misc.h"

#include <fstream>

#include <boost/filesystem.hpp>
#include <unistd.h>

namespace colmap {
namespace {

std::string TemporaryPath(const std::string& path) {
  return path + ".tmp-" + std::to_string(::getpid());
}

}  // namespace

void WriteReconstructionAtomically(const Reconstruction& reconstruction,
                                   const std::string& path) {
  const std::string temporary = TemporaryPath(path);
  boost::filesystem::remove_all(temporary);
  try {
    boost::filesystem::create_directories(temporary);
    reconstruction.WriteBinary(temporary);
  } catch (...) {
    boost::system::error_code ignored;
    boost::filesystem::remove_all(temporary, ignored);
    throw;
  }

  // A folder cannot be renamed over a non-empty one: move the old one aside
  // first, then drop it.
  const std::string previous = path + ".old-" + std::to_string(::getpid());
  const bool had_previous = boost::filesystem::exists(path);
  if (had_previous) {
    boost::filesystem::rename(path, previous);
  }
  boost::filesystem::rename(temporary, path);
  if (had_previous) {
    boost::filesystem::remove_all(previous);
  }
}

void WriteTextFileAtomically(const std::string& text, const std::string& path) {
  const std::string temporary = TemporaryPath(path);
  {
    std::ofstream file(temporary, std::ios::trunc);
    THROW_CHECK_FILE_OPEN(file, temporary);
    file << text;
    file.close();
    THROW_CHECK(file.good()) << "Could not write " << temporary;
  }
  boost::filesystem::rename(temporary, path);
}

bool IsModelDir(const std::string& path) {
  for (const std::string& name : {"cameras", "images", "points3D"}) {
    if (ExistsFile(JoinPaths(path, name + ".bin")) ||
        ExistsFile(JoinPaths(path, name + ".txt"))) {
      return true;
    }
  }
  return false;
}

}  // namespace colmap
