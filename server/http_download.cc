// Result downloads: files are streamed from disk by a content provider (never read whole),
// with a strong ETag (size + modification time) for If-None-Match / 304, and byte ranges
// (cpp-httplib turns req.ranges into 206 + Content-Range once a length-aware provider is set;
// unsatisfiable ranges are answered with 416 here, which cpp-httplib 0.11 does not do).
// Map tiles: ?format=quantized picks the KHR_mesh_quantization variant of a tile or tileset;
// tiles are immutable once written (long-lived cache), everything else is no-cache + ETag.
#include <sys/stat.h>

#include <cstdio>
#include <memory>
#include <vector>

#include <fmt/format.h>

#include "api/api_error.h"
#include "engine/core/error.h"
#include "server/http_context.h"

namespace glam::server {
namespace {

std::string ContentTypeFor(const std::string& name) {
  auto ends_with = [&](const char* suffix) {
    const std::string s(suffix);
    return name.size() >= s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0;
  };
  if (ends_with(".geojson")) return "application/geo+json";
  if (ends_with(".json")) return "application/json";
  if (ends_with(".glb")) return "model/gltf-binary";
  if (ends_with(".tum") || ends_with(".txt")) return "text/plain; charset=utf-8";
  if (ends_with(".ply")) return "application/octet-stream";
  return "application/octet-stream";
}

bool EtagMatches(const std::string& header, const std::string& etag) {
  if (header == "*") return true;
  std::size_t start = 0;
  while (start < header.size()) {
    std::size_t end = header.find(',', start);
    if (end == std::string::npos) end = header.size();
    std::string token = header.substr(start, end - start);
    const auto first = token.find_first_not_of(' ');
    const auto last = token.find_last_not_of(' ');
    if (first != std::string::npos) token = token.substr(first, last - first + 1);
    if (token.rfind("W/", 0) == 0) token = token.substr(2);
    if (token == etag) return true;
    start = end + 1;
  }
  return false;
}

}  // namespace

void HandleDownload(Context& ctx, const httplib::Request& req, httplib::Response& res,
                    const std::string& file_name) {
  const std::string id = JobIdParam(req);
  std::string name = file_name;
  const bool open_route = name == "tiles/{submap}.open.glb";
  const bool tile = open_route || name == "tiles/{submap}.glb";
  if (tile) name = "tiles/" + std::string(req.matches[2]) + (open_route ? ".open.glb" : ".glb");
  constexpr std::string_view kPart = "{part}";
  if (const std::size_t at = name.find(kPart); at != std::string::npos) {
    name.replace(at, kPart.size(), std::string(req.matches[2]));
  }
  // ?format=quantized: the KHR_mesh_quantization variant of a tile, or the tileset that
  // points at those variants (for standard 3D Tiles clients, which cannot read Draco points).
  const std::string format = req.get_param_value("format");
  if (!format.empty() && (tile || name == "tileset.json")) {
    if (format == "quantized") {
      name = tile ? name.substr(0, name.size() - 4) + ".quantized.glb" : "tileset.quantized.json";
    } else if (format != "draco") {
      throw api::ApiError(400, "bad_request",
                          fmt::format("format must be draco or quantized, not '{}'", format));
    }
  }
  const std::filesystem::path path = ctx.service.ResultFile(id, name);
  // The open submap's preview tile (tiles/<n>.open.glb, also reached as the quantized variant
  // tiles/<n>.open.quantized.glb) is rewritten as the submap grows (its URIs in tileset.json
  // are versioned), so unlike a submap's own tile it is not immutable.
  const bool open_tile = tile && name.find(".open.") != std::string::npos;

  struct stat info {};
  std::FILE* raw = std::fopen(path.c_str(), "rb");
  if (raw == nullptr || fstat(fileno(raw), &info) != 0) {
    if (raw != nullptr) std::fclose(raw);
    throw api::ApiError(404, "not_found", fmt::format("{} disappeared", name));
  }
  std::shared_ptr<std::FILE> file(raw, [](std::FILE* f) { std::fclose(f); });
  const auto size = static_cast<std::size_t>(info.st_size);
  const std::string etag = fmt::format("\"{:x}-{:x}{:09}\"", size, info.st_mtim.tv_sec, info.st_mtim.tv_nsec);
  res.set_header("ETag", etag);
  res.set_header("Accept-Ranges", "bytes");
  // A submap's tile is written once, when it completes, and never changes: cache it for good.
  // Everything else (tileset.json gets a new revision on every alignment) is revalidated.
  res.set_header("Cache-Control", tile && !open_tile ? "public, max-age=31536000, immutable" : "no-cache");
  if (req.has_header("If-None-Match") && EtagMatches(req.get_header_value("If-None-Match"), etag)) {
    res.status = 304;
    return;
  }
  for (const auto& [first, last] : req.ranges) {
    // (-1, n): last n bytes; (n, -1): from n to the end.
    const bool unsatisfiable = (first >= 0 && static_cast<std::size_t>(first) >= size) ||
                               (first < 0 && last <= 0) || (first >= 0 && last >= 0 && last < first);
    if (unsatisfiable) {
      res.set_header("Content-Range", fmt::format("bytes */{}", size));
      throw api::ApiError(416, "range_not_satisfiable",
                          fmt::format("{} has {} bytes; the requested range is outside", name, size));
    }
  }
  res.set_content_provider(
      size, ContentTypeFor(name),
      [file](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
        std::vector<char> buffer(std::min<std::size_t>(length, 256 * 1024));
        if (std::fseek(file.get(), static_cast<long>(offset), SEEK_SET) != 0) return false;
        const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), file.get());
        if (n == 0) return false;
        return sink.write(buffer.data(), n);
      });
}

}  // namespace glam::server
