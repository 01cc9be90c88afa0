// Access to a COLMAP database that another process may hold for a moment:
// opening one runs COLMAP's schema statements, which hold SQLite's write
// lock briefly, so the tasks of a job array that start together find it
// locked ("database is locked").

#pragma once

#include <functional>
#include <string>

namespace colmap {

// From this call on, every SQLite connection the process opens (COLMAP's
// Database and this extension's own) waits up to `timeout_seconds` for a
// lock another connection holds, where SQLite's default is to fail at once.
// Calling it again changes the wait.
void WaitOnLockedDatabases(double timeout_seconds = 60.0);

struct DatabaseRetryOptions {
  // Attempts in all, the first included.
  int max_num_attempts = 5;
  // The wait after the k-th failed attempt is k times this.
  double wait_seconds = 1.0;

  bool Check() const;
};

// Calls `access` until it returns true, at most `max_num_attempts` times. An
// exception it throws (as SQLite's "database is locked") counts as a failed
// attempt; each failure is logged with `database_path` and the wait before
// the next. Returns whether an attempt succeeded; `last_error`, if given,
// receives the message of the last attempt's exception (empty where it
// returned false instead).
bool RetryDatabaseAccess(const std::string& database_path,
                         const std::function<bool()>& access,
                         const DatabaseRetryOptions& options = {},
                         std::string* last_error = nullptr);

// As RetryDatabaseAccess, for an access that either succeeds or throws: once
// every attempt threw, throws std::runtime_error naming `database_path` and
// the last attempt's error.
void RetryDatabaseAccessOrThrow(const std::string& database_path,
                                const std::function<void()>& access,
                                const DatabaseRetryOptions& options = {});

}  // namespace colmap
