// Range checks of options that name the flag as a user types it.
//
// COLMAP's CHECK_OPTION_* log the failed expression, which names a struct
// field; a user typed `--CommunityMapper.pairwise_min_num_inliers`. The
// options structs check the fields that are flags with CheckFlag, so the
// refusal says which flag, its value, and what it must be.
#pragma once

#include "colmap/util/logging.h"

#include <string>

namespace colmap {

// Where `valid` is false, logs "--CommunityMapper.NAME is VALUE: it must be
// REQUIREMENT." Returns `valid`.
template <typename T>
bool CheckFlag(const bool valid,
               const std::string& name,
               const T& value,
               const std::string& requirement) {
  LOG_IF(ERROR, !valid) << "--CommunityMapper." << name << " is " << value
                        << ": it must be " << requirement << ".";
  return valid;
}

}  // namespace colmap
