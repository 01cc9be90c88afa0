#include "colmap_ext/workflow/database_retry.h"

#include "colmap/util/logging.h"

#include <atomic>
#include <chrono>
#include <exception>
#include <stdexcept>
#include <thread>

#include <sqlite3.h>

namespace colmap {
namespace {

std::atomic<int> busy_timeout_milliseconds{0};

// Run by SQLite as each connection opens (an automatic extension).
int SetBusyTimeout(sqlite3* database,
                   const char** /*error_message*/,
                   const void* /*api*/) {
  sqlite3_busy_timeout(database, busy_timeout_milliseconds.load());
  return SQLITE_OK;
}

}  // namespace

void WaitOnLockedDatabases(const double timeout_seconds) {
  THROW_CHECK_GE(timeout_seconds, 0);
  busy_timeout_milliseconds = static_cast<int>(timeout_seconds * 1000);
  // Registering an extension that is already registered does nothing.
  THROW_CHECK_EQ(
      sqlite3_auto_extension(reinterpret_cast<void (*)()>(&SetBusyTimeout)),
      SQLITE_OK);
}

bool DatabaseRetryOptions::Check() const {
  CHECK_OPTION_GT(max_num_attempts, 0);
  CHECK_OPTION_GE(wait_seconds, 0);
  return true;
}

bool RetryDatabaseAccess(const std::string& database_path,
                         const std::function<bool()>& access,
                         const DatabaseRetryOptions& options,
                         std::string* last_error) {
  THROW_CHECK(options.Check());
  for (int attempt = 1;; ++attempt) {
    std::string error;
    bool succeeded = false;
    try {
      succeeded = access();
    } catch (const std::exception& exception) {
      error = exception.what();
    }
    if (last_error != nullptr) {
      *last_error = error;
    }
    if (succeeded) {
      return true;
    }
    if (attempt == options.max_num_attempts) {
      LOG(WARNING) << "Giving up on " << database_path << " after " << attempt
                   << " attempts" << (error.empty() ? "" : " (" + error + ")");
      return false;
    }
    const double wait_seconds = attempt * options.wait_seconds;
    LOG(WARNING) << "Reading " << database_path << " failed ("
                 << (error.empty()
                         ? "found nothing: is another process opening it?"
                         : error)
                 << "); trying again in " << wait_seconds << "s";
    std::this_thread::sleep_for(std::chrono::duration<double>(wait_seconds));
  }
}

void RetryDatabaseAccessOrThrow(const std::string& database_path,
                                const std::function<void()>& access,
                                const DatabaseRetryOptions& options) {
  std::string error;
  if (!RetryDatabaseAccess(
          database_path,
          [&]() {
            access();
            return true;
          },
          options,
          &error)) {
    throw std::runtime_error("Could not read the database " + database_path +
                             ": " + error);
  }
}

}  // namespace colmap
