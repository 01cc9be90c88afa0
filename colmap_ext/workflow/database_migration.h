// Databases written by COLMAP 3, opened by COLMAP 4.
//
// COLMAP 4 migrates an older database in place the first time it opens one:
// rigs and frames, the pose priors' new layout, NULL for unknown geometry.
// For a user's database that is unsafe twice over. The migration of a COLMAP
// 3.10 database stops halfway (its pose_priors table has no
// position_covariance column, which the migration copies), and in place
// means that the database COLMAP 3 wrote is gone without a word.
// MigrateColmap3Database migrates a copy, adding first the column COLMAP 3
// did not have (an unknown covariance, NaN, as COLMAP 4 writes it), and puts
// the copy in the database's place only once COLMAP 4 opened it; the
// original stays beside it, for COLMAP 3.

#pragma once

#include <string>

namespace colmap {

// Whether the file at `path` is a COLMAP database without COLMAP 4's rigs
// and frames tables (false for a missing file or an empty one).
bool IsColmap3Database(const std::string& path);

// Where MigrateColmap3Database keeps the original.
inline std::string Colmap3BackupPath(const std::string& path) {
  return path + ".colmap3";
}

// Migrates the COLMAP 3 database at `path` as above, the original renamed to
// Colmap3BackupPath(path). Throws, with `path` as it was, where any step
// fails or the backup path is taken.
void MigrateColmap3Database(const std::string& path);

}  // namespace colmap
