#include "colmap_ext/workflow/database_migration.h"

#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/scene/database.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/file.h"

#include <filesystem>

#include <gtest/gtest.h>
#include <sqlite3.h>

namespace colmap {
namespace {

// A database as COLMAP 3.10 writes it (its schema, user_version 3900): two
// cameras, three images, a pose prior for the first image and a verified
// pair without matches.
void WriteColmap3Database(const std::string& path) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  const char* sql =
      "CREATE TABLE cameras (camera_id INTEGER PRIMARY KEY AUTOINCREMENT NOT "
      "NULL, model INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER "
      "NOT NULL, params BLOB, prior_focal_length INTEGER NOT NULL);"
      "CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT "
      "NULL, name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT NULL, "
      "CONSTRAINT image_id_check CHECK(image_id >= 0 and image_id < "
      "2147483647), FOREIGN KEY(camera_id) REFERENCES cameras(camera_id));"
      "CREATE UNIQUE INDEX index_name ON images(name);"
      "CREATE TABLE pose_priors (image_id INTEGER PRIMARY KEY NOT NULL, "
      "position BLOB, coordinate_system INTEGER NOT NULL, FOREIGN "
      "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);"
      "CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY NOT NULL, rows "
      "INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB, FOREIGN "
      "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);"
      "CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY NOT NULL, rows "
      "INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB, FOREIGN "
      "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);"
      "CREATE TABLE matches (pair_id INTEGER PRIMARY KEY NOT NULL, rows "
      "INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB);"
      "CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY NOT "
      "NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB, config "
      "INTEGER NOT NULL, F BLOB, E BLOB, H BLOB, qvec BLOB, tvec BLOB);"
      "INSERT INTO images VALUES (1, 'a.jpg', 1), (2, 'b.jpg', 1), "
      "(3, 'c.jpg', 2);"
      "INSERT INTO two_view_geometries VALUES (2147483649, 0, 2, NULL, 2, "
      "NULL, NULL, NULL, NULL, NULL);"
      "PRAGMA user_version = 3900;";
  ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  // Blobs in COLMAP's layout: raw doubles. Two SIMPLE_PINHOLE cameras
  // (focal length, principal point) and the prior's position (1, 2, 3).
  const double params[3] = {500, 320, 240};
  sqlite3_stmt* statement = nullptr;
  for (int camera_id = 1; camera_id <= 2; ++camera_id) {
    ASSERT_EQ(sqlite3_prepare_v2(
                  db,
                  "INSERT INTO cameras VALUES (?, 0, 640, 480, ?, 0);",
                  -1,
                  &statement,
                  nullptr),
              SQLITE_OK);
    sqlite3_bind_int(statement, 1, camera_id);
    sqlite3_bind_blob(statement, 2, params, sizeof(params), SQLITE_STATIC);
    ASSERT_EQ(sqlite3_step(statement), SQLITE_DONE);
    sqlite3_finalize(statement);
  }
  const double position[3] = {1, 2, 3};
  ASSERT_EQ(sqlite3_prepare_v2(
                db,
                "INSERT INTO pose_priors VALUES (1, ?, 1);",
                -1,
                &statement,
                nullptr),
            SQLITE_OK);
  sqlite3_bind_blob(statement, 1, position, sizeof(position), SQLITE_STATIC);
  ASSERT_EQ(sqlite3_step(statement), SQLITE_DONE);
  sqlite3_finalize(statement);
  sqlite3_close(db);
}

TEST(MigrateColmap3Database, GivesAColmap4DatabaseAndKeepsTheOriginal) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "database.db").string();
  WriteColmap3Database(path);
  ASSERT_TRUE(IsColmap3Database(path));

  MigrateColmap3Database(path);

  EXPECT_FALSE(IsColmap3Database(path));
  EXPECT_TRUE(IsColmap3Database(Colmap3BackupPath(path)));
  EXPECT_FALSE(ExistsFile(path + ".migrating"));
  const std::shared_ptr<Database> database = Database::Open(path);
  EXPECT_EQ(database->NumImages(), 3);
  // Without rigs and frames in the database, COLMAP gives every camera a
  // rig and every image a frame of its own as it loads it.
  DatabaseCache::Options cache_options;
  cache_options.load_all_images = true;
  const std::shared_ptr<DatabaseCache> cache =
      DatabaseCache::Create(*database, cache_options);
  EXPECT_EQ(cache->NumFrames(), 3);
  EXPECT_EQ(cache->NumRigs(), 2);
  EXPECT_EQ(database->NumVerifiedImagePairs(), 1);
  const std::vector<PosePrior> priors = database->ReadAllPosePriors();
  ASSERT_EQ(priors.size(), 1);
  EXPECT_EQ(priors[0].position, Eigen::Vector3d(1, 2, 3));
  // COLMAP 3 had no covariance: unknown, not certain.
  EXPECT_FALSE(priors[0].HasPositionCov());
}

TEST(MigrateColmap3Database, LeavesTheDatabaseAsItWasWhereItCannot) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "database.db").string();
  WriteColmap3Database(path);
  WriteTextFileAtomically("a user's file", Colmap3BackupPath(path));
  EXPECT_THROW(MigrateColmap3Database(path), std::runtime_error);
  EXPECT_TRUE(IsColmap3Database(path));
  EXPECT_EQ(ReadTextFileLines(Colmap3BackupPath(path)).front(),
            "a user's file");
}

TEST(IsColmap3Database, OnlyForADatabaseWithoutFrames) {
  const std::string folder = CreateTestFolder();
  const std::string colmap4_path =
      (std::filesystem::path(folder) / "colmap4.db").string();
  Database::Open(colmap4_path)->Close();
  EXPECT_FALSE(IsColmap3Database(colmap4_path));
  EXPECT_FALSE(
      IsColmap3Database((std::filesystem::path(folder) / "missing.db").string()));
}

}  // namespace
}  // namespace colmap
