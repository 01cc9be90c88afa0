// An SQLite connection, closed when it goes out of scope, for what COLMAP's
// Database does not do: look into a file before COLMAP opens it (and
// migrates it in place), copy it.

#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include <sqlite3.h>

namespace colmap {

class SqliteConnection {
 public:
  // Opens the database at `path` with sqlite3_open_v2's `flags`. If it
  // cannot, throws std::runtime_error("cannot open PATH: REASON"), or, given
  // `error`, sets *error to REASON and stays closed (get() is null).
  SqliteConnection(const std::string& path,
                   const int flags,
                   std::string* error = nullptr) {
    if (sqlite3_open_v2(path.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
      const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close_v2(db_);
      db_ = nullptr;
      if (error == nullptr) {
        throw std::runtime_error("cannot open " + path + ": " + message);
      }
      *error = message;
    }
  }
  ~SqliteConnection() { sqlite3_close_v2(db_); }
  SqliteConnection(const SqliteConnection&) = delete;
  SqliteConnection& operator=(const SqliteConnection&) = delete;

  sqlite3* get() const { return db_; }

  // Runs `sql`; throws std::runtime_error("SQL: REASON") if it fails.
  void Execute(const std::string& sql) const {
    char* error = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
      const std::string message = error ? error : sqlite3_errmsg(db_);
      sqlite3_free(error);
      throw std::runtime_error(sql + ": " + message);
    }
  }

  // Whether the statement `sql` gives at least one row; throws if it cannot
  // be prepared.
  bool HasRow(const std::string& sql) const {
    sqlite3_stmt* statement = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &statement, nullptr) !=
        SQLITE_OK) {
      throw std::runtime_error(sql + ": " + sqlite3_errmsg(db_));
    }
    const bool has_row = sqlite3_step(statement) == SQLITE_ROW;
    sqlite3_finalize(statement);
    return has_row;
  }

  bool HasTable(const std::string& table) const {
    return HasRow("SELECT 1 FROM sqlite_master WHERE type='table' AND name='" +
                  table + "';");
  }

  bool HasColumn(const std::string& table, const std::string& column) const {
    return HasRow("SELECT 1 FROM pragma_table_info('" + table +
                  "') WHERE name='" + column + "';");
  }

  // Runs a query returning one integer; false if it fails.
  bool QueryInteger(const std::string& sql, int64_t* value) const {
    sqlite3_stmt* statement = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &statement, nullptr) !=
        SQLITE_OK) {
      return false;
    }
    const bool ok = sqlite3_step(statement) == SQLITE_ROW;
    if (ok) {
      *value = sqlite3_column_int64(statement, 0);
    }
    sqlite3_finalize(statement);
    return ok;
  }

 private:
  sqlite3* db_ = nullptr;
};

}  // namespace colmap
