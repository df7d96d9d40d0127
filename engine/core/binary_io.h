// Little helpers for GLAM's versioned binary files (submaps, vocabulary). Every file starts
// with an 8-byte magic and a uint32 version so readers can reject foreign or future files with
// a clear message instead of misreading them. Values are written in the host's byte order,
// which is little-endian on every platform GLAM builds for (checked at compile time).
#pragma once

#include <bit>
#include <cstring>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
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

// Reads a whole file (or bytes already in memory, e.g. data embedded in the binary) and parses
// it from memory: one reader, one set of checks, whatever the source. Every read is bounds
// checked, so a truncated or corrupt file gives an InputError naming it, never a misread.
class BinaryReader {
 public:
  // Reads `path`, checks the magic and returns the version through version(); throws
  // InputError for a missing file, a foreign magic, or a version above `max_version`.
  BinaryReader(const std::filesystem::path& path, std::string_view magic, std::uint32_t max_version)
      : name_(path.string()) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(fmt::format("cannot open {}", name_));
    owned_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (in.bad()) throw InputError(fmt::format("cannot read {}", name_));
    bytes_ = owned_;
    CheckHeader(magic, max_version);
  }
  // The same over `bytes` (not copied: they must outlive the reader); `name` is used in errors.
  BinaryReader(std::span<const std::uint8_t> bytes, std::string_view name, std::string_view magic,
               std::uint32_t max_version)
      : bytes_(bytes), name_(name) {
    CheckHeader(magic, max_version);
  }

  std::uint32_t version() const { return version_; }

  template <typename T>
  T Read() {
    T value;
    ReadArray(&value, 1);
    return value;
  }
  template <typename T>
  void ReadArray(T* data, std::size_t count) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::size_t n = sizeof(T) * count;
    if (n > bytes_.size() - pos_) throw InputError(fmt::format("{} is truncated or corrupt", name_));
    std::memcpy(static_cast<void*>(data), bytes_.data() + pos_, n);
    pos_ += n;
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
      throw InputError(fmt::format("{} is corrupt: count {} exceeds {}", name_, n, max_count));
    }
    return n;
  }

 private:
  void CheckHeader(std::string_view magic, std::uint32_t max_version) {
    GLAM_CHECK(magic.size() == 8, "magic must be 8 bytes");
    if (bytes_.size() < magic.size() || std::memcmp(bytes_.data(), magic.data(), magic.size()) != 0) {
      throw InputError(fmt::format("{} is not a {} file", name_, magic));
    }
    pos_ = magic.size();
    version_ = Read<std::uint32_t>();
    if (version_ == 0 || version_ > max_version) {
      throw InputError(fmt::format("{} has format version {}, this build reads versions 1..{}", name_,
                                   version_, max_version));
    }
  }

  std::vector<std::uint8_t> owned_;  // file contents (empty for the span constructor)
  std::span<const std::uint8_t> bytes_;
  std::string name_;
  std::size_t pos_ = 0;
  std::uint32_t version_ = 0;
};

}  // namespace glam
