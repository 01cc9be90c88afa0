// One writer per output folder.
//
// A run that writes an output folder (community_mapper, its partition or its
// merge) holds the folder's lock file while it runs: a file naming its host
// and process (HOST-PID, atomic_output.h's writer tag), created only where
// none exists. A second run on the same folder is refused with the holder's
// name. A lock whose holder has ended (a process of this host that no longer
// runs: a killed run) is taken over, with a line in the log; a lock of
// another host sharing the folder is left to the user, since this host
// cannot tell whether that process still runs. The jobs of a job array
// (community_reconstructor) write different communities and hold no lock.
#pragma once

#include <string>

namespace colmap {

// The name of the lock file in the output folder.
constexpr char kOutputLockFileName[] = "lock";

class OutputLock {
 public:
  OutputLock() = default;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock() { Release(); }

  // Takes the lock of `folder`, which must exist. Returns an empty string,
  // or why the lock cannot be had (its holder, and what to do).
  std::string Acquire(const std::string& folder);

  // Releases the lock (nothing if not held).
  void Release();

 private:
  std::string path_;
};

}  // namespace colmap
