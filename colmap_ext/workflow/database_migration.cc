#include "colmap_ext/workflow/database_migration.h"

#include "colmap_ext/workflow/sqlite_connection.h"

#include "colmap/scene/database.h"
#include "colmap/util/file.h"
#include "colmap/util/logging.h"

#include <filesystem>
#include <limits>
#include <vector>

namespace colmap {
namespace {

// A consistent copy of the database at `source` (with what its write-ahead
// log holds) into `target`, through SQLite's backup API.
void CopyDatabase(const std::string& source, const std::string& target) {
  const SqliteConnection from(source, SQLITE_OPEN_READONLY);
  const SqliteConnection to(target,
                            SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  sqlite3_backup* backup = sqlite3_backup_init(to.get(), "main", from.get(), "main");
  if (backup == nullptr) {
    throw std::runtime_error("cannot copy " + source + ": " +
                             sqlite3_errmsg(to.get()));
  }
  const int result = sqlite3_backup_step(backup, -1);
  sqlite3_backup_finish(backup);
  if (result != SQLITE_DONE) {
    throw std::runtime_error("cannot copy " + source + ": " +
                             sqlite3_errstr(result));
  }
}

// COLMAP 3's pose_priors table has no position_covariance column, which
// COLMAP 4's migration copies: add it, unknown (NaN) for every prior.
void AddPositionCovariance(const SqliteConnection& database) {
  if (!database.HasTable("pose_priors") ||
      database.HasColumn("pose_priors", "position_covariance")) {
    return;
  }
  database.Execute("ALTER TABLE pose_priors ADD COLUMN position_covariance BLOB;");
  const std::vector<double> unknown(9, std::numeric_limits<double>::quiet_NaN());
  sqlite3_stmt* statement = nullptr;
  const char* sql = "UPDATE pose_priors SET position_covariance = ?;";
  if (sqlite3_prepare_v2(database.get(), sql, -1, &statement, nullptr) !=
          SQLITE_OK ||
      sqlite3_bind_blob(statement,
                        1,
                        unknown.data(),
                        static_cast<int>(unknown.size() * sizeof(double)),
                        SQLITE_TRANSIENT) != SQLITE_OK ||
      sqlite3_step(statement) != SQLITE_DONE) {
    const std::string message = sqlite3_errmsg(database.get());
    sqlite3_finalize(statement);
    throw std::runtime_error(std::string(sql) + ": " + message);
  }
  sqlite3_finalize(statement);
}

}  // namespace

bool IsColmap3Database(const std::string& path) {
  if (!ExistsFile(path) || std::filesystem::file_size(path) == 0) {
    return false;
  }
  const SqliteConnection database(path, SQLITE_OPEN_READONLY);
  return database.HasTable("images") && !database.HasTable("frames");
}

void MigrateColmap3Database(const std::string& path) {
  const std::string backup_path = Colmap3BackupPath(path);
  if (ExistsFile(backup_path)) {
    throw std::runtime_error(
        backup_path + " exists: it would be overwritten by the COLMAP 3 " +
        "database " + path + ", which must be migrated to COLMAP 4's layout. " +
        "Move it away and run again.");
  }
  const std::string migrating_path = path + ".migrating";
  std::filesystem::remove(migrating_path);
  try {
    CopyDatabase(path, migrating_path);
    AddPositionCovariance(SqliteConnection(migrating_path, SQLITE_OPEN_READWRITE));
    // COLMAP 4 migrates the copy as it opens it; the connection's close
    // folds its write-ahead log into the file.
    Database::Open(migrating_path)->Close();
  } catch (...) {
    std::filesystem::remove(migrating_path);
    std::filesystem::remove(migrating_path + "-wal");
    std::filesystem::remove(migrating_path + "-shm");
    throw;
  }
  // The original keeps its write-ahead log where a writer left one in it
  // (the copy holds what it says): renamed with it, never taken by the
  // migrated file. An empty log and the shared-memory index, which SQLite
  // rebuilds, go.
  std::filesystem::rename(path, backup_path);
  const std::string wal_path = path + "-wal";
  if (ExistsFile(wal_path) && std::filesystem::file_size(wal_path) > 0) {
    std::filesystem::rename(wal_path, backup_path + "-wal");
  }
  std::filesystem::remove(wal_path);
  std::filesystem::remove(path + "-shm");
  std::filesystem::rename(migrating_path, path);
  LOG(WARNING) << path << " was written by COLMAP 3: it now has COLMAP 4's "
               << "layout (rigs and frames), which COLMAP 3 cannot read. The "
               << "original is kept as " << backup_path << ".";
}

}  // namespace colmap
