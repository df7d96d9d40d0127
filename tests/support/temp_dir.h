// Scratch directories for tests: unique per process (several build trees may run the tests
// at the same time on one machine) and removed when the process exits.
#pragma once

#include <filesystem>
#include <string>

namespace glam::testing {

// <tmp>/glam_<name>_<pid>, emptied and created; removed at process exit.
std::filesystem::path FreshTempDir(const std::string& name);

}  // namespace glam::testing
