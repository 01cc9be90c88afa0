#include "colmap_ext/util/log_tag.h"

#include "colmap/util/logging.h"

#include <iomanip>

namespace colmap {
namespace {

thread_local std::string log_tag;

// glog's own prefix ("I20261122 03:14:12.070434  8223 file.cc:12]"), then
// the tag in brackets.
void TaggedPrefix(std::ostream& stream,
                  const google::LogMessageInfo& info,
                  void* /*data*/) {
  stream << info.severity[0] << std::setw(4) << 1900 + info.time.year()
         << std::setw(2) << std::setfill('0') << 1 + info.time.month()
         << std::setw(2) << info.time.day() << ' ' << std::setw(2)
         << info.time.hour() << ':' << std::setw(2) << info.time.min() << ':'
         << std::setw(2) << info.time.sec() << '.' << std::setw(6)
         << info.time.usec() << ' ' << std::setfill(' ') << std::setw(5)
         << info.thread_id << std::setfill('0') << ' ' << info.filename << ':'
         << info.line_number << "]";
  if (!log_tag.empty()) {
    stream << " [" << log_tag << "]";
  }
}

}  // namespace

ScopedLogTag::ScopedLogTag(const std::string& tag) : previous_tag_(log_tag) {
  log_tag = tag;
}

ScopedLogTag::~ScopedLogTag() { log_tag = previous_tag_; }

void InstallTaggedLogPrefix(const char* program_name) {
  if (google::IsGoogleLoggingInitialized()) {
    google::ShutdownGoogleLogging();
  }
  google::InitGoogleLogging(program_name, &TaggedPrefix, nullptr);
}

}  // namespace colmap
