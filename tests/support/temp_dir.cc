#include "tests/support/temp_dir.h"

#include <unistd.h>

#include <mutex>
#include <vector>

namespace glam::testing {

namespace fs = std::filesystem;

fs::path FreshTempDir(const std::string& name) {
  struct Cleanup {
    std::mutex mutex;
    std::vector<fs::path> dirs;
    ~Cleanup() {
      for (const fs::path& d : dirs) {
        std::error_code ec;
        fs::remove_all(d, ec);
      }
    }
  };
  static Cleanup cleanup;
  const fs::path dir = fs::temp_directory_path() / ("glam_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::lock_guard lock(cleanup.mutex);
  cleanup.dirs.push_back(dir);
  return dir;
}

}  // namespace glam::testing
