// Little helpers for GLAM's versioned binary files (submaps, vocabulary). Every file starts
// with an 8-byte magic and a uint32 version so readers can reject foreign or future files with
// a clear message instead of misreading them. Values are written in the host's byte order,
// which is little-endian on every platform GLAM builds for (checked at compile time).
#pragma once

#include <bit>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <fmt/format.h>

#include "engine/core/error.h"

namespace glam {

static_assert(std::endian::native == std::endian::little, "GLAM binary files are little-endian");

class BinaryWriter {
 public:
  // Writes to `path` + ".tmp" and renames on Finish(), so a crash never leaves a half file
  // under the final name (readers after a restart see either the old or the new file).
  BinaryWriter(std::filesystem::path path, std::string_view magic, std::uint32_t version)
      : path_(std::move(path)), tmp_path_(path_.string() + ".tmp"), out_(tmp_path_, std::ios::binary) {
    if (!out_) throw EnvironmentError(fmt::format("cannot write {}", tmp_path_.string()));
    GLAM_CHECK(magic.size() == 8, "magic must be 8 bytes");
    out_.write(magic.data(), 8);
    Write(version);
  }

  template <typename T>
  void Write(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.write(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <typename T>
  void WriteArray(const T* data, std::size_t count) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(sizeof(T) * count));
  }
  void WriteString(const std::string& s) {
    Write<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    WriteArray(s.data(), s.size());
  }

  void Finish() {
    out_.flush();
    if (!out_) throw EnvironmentError(fmt::format("write failed for {} (disk full?)", tmp_path_.string()));
    out_.close();
    std::filesystem::rename(tmp_path_, path_);
  }

 private:
  std::filesystem::path path_;
  std::filesystem::path tmp_path_;
  std::ofstream out_;
};

class BinaryReader {
 public:
  // Opens `path`, checks the magic and returns the version through version(); throws
  // InputError for a missing file, a foreign magic, or a version above `max_version`.
  BinaryReader(const std::filesystem::path& path, std::string_view magic, std::uint32_t max_version)
      : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw InputError(fmt::format("cannot open {}", path.string()));
    char got[8] = {};
    in_.read(got, 8);
    if (!in_ || std::string_view(got, 8) != magic) {
      throw InputError(fmt::format("{} is not a {} file", path.string(), magic));
    }
    version_ = Read<std::uint32_t>();
    if (version_ == 0 || version_ > max_version) {
      throw InputError(fmt::format("{} has format version {}, this build reads versions 1..{}",
                                   path.string(), version_, max_version));
    }
  }

  std::uint32_t version() const { return version_; }

  template <typename T>
  T Read() {
    static_assert(std::is_trivially_copyable_v<T>);
    T value;
    in_.read(reinterpret_cast<char*>(&value), sizeof(T));
    if (!in_) Truncated();
    return value;
  }
  template <typename T>
  void ReadArray(T* data, std::size_t count) {
    static_assert(std::is_trivially_copyable_v<T>);
    in_.read(reinterpret_cast<char*>(data), static_cast<std::streamsize>(sizeof(T) * count));
    if (!in_) Truncated();
  }
  std::string ReadString() {
    const auto size = ReadCount(1 << 20);
    std::string s(size, '\0');
    ReadArray(s.data(), size);
    return s;
  }
  // Reads a uint32 element count and rejects absurd values before anything is allocated.
  std::uint32_t ReadCount(std::uint32_t max_count) {
    const auto n = Read<std::uint32_t>();
    if (n > max_count) {
      throw InputError(fmt::format("{} is corrupt: count {} exceeds {}", path_.string(), n, max_count));
    }
    return n;
  }

 private:
  [[noreturn]] void Truncated() const {
    throw InputError(fmt::format("{} is truncated or corrupt", path_.string()));
  }

  std::filesystem::path path_;
  std::ifstream in_;
  std::uint32_t version_ = 0;
};

}  // namespace glam
