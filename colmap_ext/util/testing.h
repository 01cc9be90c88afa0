// Helpers for colmap_ext's tests (linked into the test binaries only).

#pragma once

#include <string>

namespace colmap {

// A new, empty folder for the running test, named after it. (Not
// CreateTestDir: COLMAP's tests define colmap::CreateTestDir.)
std::string CreateTestFolder();

// Runs a shell command, capturing stdout and stderr together. Returns its
// exit status (-1 if it could not be run or was killed).
int RunCommand(const std::string& command, std::string* output = nullptr);

// Quotes a string for the shell.
std::string ShellQuote(const std::string& text);

}  // namespace colmap
