#include "engine/core/atomic_file.h"

#include <fstream>
#include <string>

#include <fmt/format.h>

#include "engine/core/error.h"

namespace glam {

void WriteFileAtomically(const std::filesystem::path& path, std::string_view contents) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.close();
    if (!out) throw EnvironmentError(fmt::format("cannot write {}", tmp.string()));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw EnvironmentError(fmt::format("cannot write {}: {}", path.string(), ec.message()));
  }
}

}  // namespace glam
