#include "colmap_ext/workflow/database_retry.h"

#include "colmap_ext/testing/testing.h"

#include "colmap/scene/database.h"

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>
#include <sqlite3.h>

namespace colmap {
namespace {

DatabaseRetryOptions QuickOptions() {
  DatabaseRetryOptions options;
  options.max_num_attempts = 4;
  options.wait_seconds = 0.001;
  return options;
}

TEST(RetryDatabaseAccess, TriesAgainUntilAnAttemptSucceeds) {
  int num_calls = 0;
  std::string last_error = "not cleared";
  EXPECT_TRUE(RetryDatabaseAccess(
      "db",
      [&]() {
        ++num_calls;
        if (num_calls == 1) {
          throw std::runtime_error("database is locked");
        }
        return num_calls == 3;
      },
      QuickOptions(),
      &last_error));
  EXPECT_EQ(num_calls, 3);
  EXPECT_EQ(last_error, "");
}

TEST(RetryDatabaseAccess, GivesUpAfterItsAttemptsWithTheLastError) {
  int num_calls = 0;
  std::string last_error;
  EXPECT_FALSE(RetryDatabaseAccess(
      "db",
      [&]() -> bool {
        ++num_calls;
        throw std::runtime_error("locked " + std::to_string(num_calls));
      },
      QuickOptions(),
      &last_error));
  EXPECT_EQ(num_calls, 4);
  EXPECT_EQ(last_error, "locked 4");

  num_calls = 0;
  EXPECT_FALSE(RetryDatabaseAccess(
      "db", [&]() { return ++num_calls < 0; }, QuickOptions(), &last_error));
  EXPECT_EQ(num_calls, 4);
  EXPECT_EQ(last_error, "");
}

TEST(RetryDatabaseAccessOrThrow, ThrowsTheLastErrorWithThePath) {
  int num_calls = 0;
  RetryDatabaseAccessOrThrow(
      "db",
      [&]() {
        if (++num_calls < 2) {
          throw std::runtime_error("database is locked");
        }
      },
      QuickOptions());
  EXPECT_EQ(num_calls, 2);

  num_calls = 0;
  try {
    RetryDatabaseAccessOrThrow(
        "some.db",
        [&]() {
          throw std::runtime_error("locked " + std::to_string(++num_calls));
        },
        QuickOptions());
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()),
              "Could not read the database some.db: locked 4");
  }
  EXPECT_EQ(num_calls, 4);
}

// Creates a COLMAP database at `path` and holds it locked, as another
// process would: `holder` is a connection in SQLite's exclusive locking mode
// after a write, which keeps the lock until it is closed.
void HoldLockedDatabase(const std::string& path, sqlite3** holder) {
  Database::Open(path)->Close();
  ASSERT_EQ(sqlite3_open(path.c_str(), holder), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(*holder,
                         "PRAGMA locking_mode=EXCLUSIVE; BEGIN EXCLUSIVE; "
                         "CREATE TABLE held (x INTEGER); COMMIT;",
                         nullptr,
                         nullptr,
                         nullptr),
            SQLITE_OK);
}

// Another process keeps the database locked while the first attempts open
// it; once it lets go, the opening succeeds.
TEST(RetryDatabaseAccess, OpensADatabaseOnceItsLockIsReleased) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "database.db").string();
  sqlite3* holder = nullptr;
  ASSERT_NO_FATAL_FAILURE(HoldLockedDatabase(path, &holder));
  int num_calls = 0;
  std::string last_error;
  EXPECT_TRUE(RetryDatabaseAccess(
      path,
      [&]() {
        if (++num_calls == 3) {
          sqlite3_close(holder);
          holder = nullptr;
        }
        return Database::Open(path)->NumImages() == 0;
      },
      QuickOptions(),
      &last_error));
  EXPECT_EQ(num_calls, 3);
  EXPECT_EQ(last_error, "");
  if (holder != nullptr) {
    sqlite3_close(holder);
  }
}

// As above, but the opening itself waits for the lock to go, as every
// connection does once WaitOnLockedDatabases was called.
TEST(WaitOnLockedDatabases, OpeningWaitsForAnotherConnectionsLock) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "database.db").string();
  sqlite3* holder = nullptr;
  ASSERT_NO_FATAL_FAILURE(HoldLockedDatabase(path, &holder));
  EXPECT_THROW(Database::Open(path), std::exception);

  WaitOnLockedDatabases(30);
  std::thread releaser([holder]() {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    sqlite3_close(holder);
  });
  EXPECT_EQ(Database::Open(path)->NumImages(), 0);
  releaser.join();
  // Later tests see SQLite's default again.
  WaitOnLockedDatabases(0);
}

}  // namespace
}  // namespace colmap
