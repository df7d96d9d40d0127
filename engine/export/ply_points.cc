#include "engine/export/ply_points.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "engine/core/error.h"

namespace glam {
namespace {

static_assert(std::endian::native == std::endian::little,
              "points.ply is read and written as little-endian memory images");

// On-disk record of one vertex in the binary layout: 3 floats + 3 bytes, no padding.
constexpr std::size_t kRecordSize = 3 * sizeof(float) + 3;

constexpr const char* kPropertyNames[6] = {"x", "y", "z", "red", "green", "blue"};

enum class Encoding { kBinaryLittleEndian, kAscii };

struct Header {
  Encoding encoding = Encoding::kBinaryLittleEndian;
  std::size_t vertex_count = 0;
};

[[noreturn]] void Reject(const std::filesystem::path& path, const std::string& why) {
  throw InputError(
      fmt::format("{}: unsupported PLY ({}); expected one 'vertex' element with properties "
                  "'float x, float y, float z, uchar red, uchar green, uchar blue'",
                  path.string(), why));
}

bool IsFloatType(const std::string& t) { return t == "float" || t == "float32"; }
bool IsUcharType(const std::string& t) { return t == "uchar" || t == "uint8"; }

Header ReadHeader(std::istream& in, const std::filesystem::path& path) {
  std::string line;
  if (!std::getline(in, line) || (line != "ply" && line != "ply\r")) {
    throw InputError(fmt::format("{} is not a PLY file (no 'ply' magic line)", path.string()));
  }
  Header header;
  bool have_format = false;
  bool have_vertex = false;
  int properties = 0;
  while (true) {
    if (!std::getline(in, line)) Reject(path, "header has no 'end_header'");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header") break;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      if (format == "binary_little_endian") {
        header.encoding = Encoding::kBinaryLittleEndian;
      } else if (format == "ascii") {
        header.encoding = Encoding::kAscii;
      } else {
        Reject(path, fmt::format("format '{}'", format));
      }
      if (version != "1.0") Reject(path, fmt::format("format version '{}'", version));
      have_format = true;
    } else if (keyword == "element") {
      std::string name;
      long long count = -1;
      words >> name >> count;
      if (name != "vertex" || have_vertex) Reject(path, fmt::format("element '{}'", name));
      if (!words || count < 0) Reject(path, "bad vertex count");
      header.vertex_count = static_cast<std::size_t>(count);
      have_vertex = true;
    } else if (keyword == "property") {
      std::string type, name;
      words >> type >> name;
      if (!have_vertex || properties >= 6 || name != kPropertyNames[properties] ||
          !(properties < 3 ? IsFloatType(type) : IsUcharType(type))) {
        Reject(path, fmt::format("property '{}'", line));
      }
      ++properties;
    } else {
      Reject(path, fmt::format("header line '{}'", line));
    }
  }
  if (!have_format) Reject(path, "no format line");
  if (!have_vertex || properties != 6) Reject(path, "vertex properties missing");
  return header;
}

void CheckFinite(const ColoredPoint& p, std::size_t index, const std::filesystem::path& path) {
  if (!p.position.allFinite()) {
    throw InputError(
        fmt::format("{}: vertex {} has a non-finite coordinate", path.string(), index));
  }
}

void ReadBinaryBody(std::istream& in, const Header& header, const std::filesystem::path& path,
                    std::vector<ColoredPoint>& points) {
  // Chunked so that a header announcing billions of vertices fails at the truncation, not
  // with an allocation of the announced size.
  constexpr std::size_t kChunk = 1 << 16;
  std::vector<char> buffer(kChunk * kRecordSize);
  std::size_t done = 0;
  while (done < header.vertex_count) {
    const std::size_t n = std::min(kChunk, header.vertex_count - done);
    in.read(buffer.data(), static_cast<std::streamsize>(n * kRecordSize));
    if (!in) {
      throw InputError(fmt::format("{} is truncated: header announces {} vertices", path.string(),
                                   header.vertex_count));
    }
    for (std::size_t k = 0; k < n; ++k) {
      const char* record = buffer.data() + k * kRecordSize;
      ColoredPoint p;
      std::memcpy(p.position.data(), record, 3 * sizeof(float));
      std::memcpy(p.color.data(), record + 3 * sizeof(float), 3);
      CheckFinite(p, done + k, path);
      points.push_back(p);
    }
    done += n;
  }
}

void ReadAsciiBody(std::istream& in, const Header& header, const std::filesystem::path& path,
                   std::vector<ColoredPoint>& points) {
  for (std::size_t index = 0; index < header.vertex_count; ++index) {
    ColoredPoint p;
    int rgb[3];
    if (!(in >> p.position.x() >> p.position.y() >> p.position.z() >> rgb[0] >> rgb[1] >> rgb[2])) {
      throw InputError(fmt::format("{}: vertex {} of {} is missing or malformed", path.string(),
                                   index, header.vertex_count));
    }
    for (int c = 0; c < 3; ++c) {
      if (rgb[c] < 0 || rgb[c] > 255) {
        throw InputError(fmt::format("{}: vertex {} has colour value {} outside 0..255",
                                     path.string(), index, rgb[c]));
      }
      p.color[c] = static_cast<std::uint8_t>(rgb[c]);
    }
    CheckFinite(p, index, path);
    points.push_back(p);
  }
}

}  // namespace

void WritePlyPoints(const std::filesystem::path& path, const std::vector<ColoredPoint>& points) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw EnvironmentError(fmt::format("cannot write {}", path.string()));
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << points.size()
      << "\nproperty float x\nproperty float y\nproperty float z\n"
         "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  char record[kRecordSize];
  for (const ColoredPoint& p : points) {
    std::memcpy(record, p.position.data(), 3 * sizeof(float));
    std::memcpy(record + 3 * sizeof(float), p.color.data(), 3);
    out.write(record, kRecordSize);
  }
  out.flush();
  if (!out) throw EnvironmentError(fmt::format("write failed for {} (disk full?)", path.string()));
}

std::vector<ColoredPoint> ReadPlyPoints(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("cannot open point cloud {}", path.string()));
  const Header header = ReadHeader(in, path);
  std::vector<ColoredPoint> points;
  if (header.encoding == Encoding::kBinaryLittleEndian) {
    ReadBinaryBody(in, header, path, points);
  } else {
    ReadAsciiBody(in, header, path, points);
  }
  return points;
}

}  // namespace glam
