// Log lines tagged with what the logging thread works on.
//
// Community reconstructions run in parallel, and COLMAP's incremental mapper
// logs a great deal from each. With the tagged prefix installed, every glog
// line written by a thread inside a ScopedLogTag carries the tag, e.g.
//   I20261122 03:14:12.070434  8223 incremental_mapper.cc:369] [community 3]
//   Registering image #41 (12)
// whichever library the line comes from.

#pragma once

#include <string>

namespace colmap {

// Tags the calling thread's log lines while it lives.
class ScopedLogTag {
 public:
  explicit ScopedLogTag(const std::string& tag);
  ~ScopedLogTag();

 private:
  std::string previous_tag_;
};

// Re-initialises glog with a prefix that is glog's usual one followed by the
// thread's tag, if any. Call from the main thread before other threads log;
// without it, tags are kept but not shown.
void InstallTaggedLogPrefix(const char* program_name);

}  // namespace colmap
