// Helpers for colmap_ext's tests (linked into the test binaries only).

#pragma once

#include <string>

namespace colmap {

// A new, empty folder for the running test, named after it.
std::string CreateTestDir();

}  // namespace colmap
