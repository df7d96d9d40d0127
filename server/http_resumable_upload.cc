// /api/v1/uploads: resumable uploads over HTTP (api/upload_store.h holds the sessions).
//
//   POST   /api/v1/uploads        {"size": N, "filename": "DJI_0042.MP4"}  -> 201 session
//   PATCH  /api/v1/uploads/{id}   Upload-Offset: K, raw bytes               -> 200 session
//   GET    /api/v1/uploads/{id}                                            -> 200 session
//   DELETE /api/v1/uploads/{id}                                            -> 204
//   POST   /api/v1/jobs           {"upload_id": id, "options": {...}}      -> 201 job
// and for photos, an image set:
//   POST   /api/v1/uploads        {"kind": "images", "size": N (all photos), "filename": "survey"}
//   PUT    /api/v1/uploads/{id}/images/{name}   one whole photo            -> 200 session
//
// Every answer about a session carries its offset in an Upload-Offset header as well as in
// the JSON, so a client can resume from a HEAD (GET without body) alone. A PATCH keeps the
// bytes that arrived even when its connection breaks: the client asks for the offset and sends
// the rest.
#include <optional>

#include <fmt/format.h>

#include "api/api_error.h"
#include "api/ids.h"
#include "server/http_context.h"

namespace glam::server {
namespace {

using api::ApiError;

constexpr const char* kOffsetHeader = "Upload-Offset";

void SendSession(Context& ctx, httplib::Response& res, int status, const api::UploadSession& session,
                 bool list_images = true) {
  res.set_header(kOffsetHeader, std::to_string(session.offset));
  res.set_header("Cache-Control", "no-store");
  SendJson(res, status, api::UploadToJson(session, ctx.uploads.options().expiry, list_images));
}

// The offset a PATCH claims to start at (400 unless a plain non-negative integer).
std::int64_t RequestOffset(const httplib::Request& req) {
  if (!req.has_header(kOffsetHeader)) {
    throw ApiError(400, "bad_request",
                   "a PATCH of an upload needs an Upload-Offset header: the byte offset its body starts at "
                   "(GET the upload for the offset the server has)");
  }
  const std::string text = req.get_header_value(kOffsetHeader);
  long long value = 0;
  if (!api::ParseNonNegativeInt(text, &value)) {
    throw ApiError(400, "bad_request", fmt::format("Upload-Offset must be a non-negative integer, got \"{}\"", text));
  }
  return value;
}

// The session's offset on a refusal, so the client can resume without another request.
void AddOffsetHeader(Context& ctx, const std::string& id, httplib::Response& res) {
  try {
    res.set_header(kOffsetHeader, std::to_string(ctx.uploads.Get(id).offset));
  } catch (const std::exception&) {
  }
}

}  // namespace

void HandleCreateUpload(Context& ctx, const httplib::Request&, httplib::Response& res,
                        const httplib::ContentReader& reader) {
  const nlohmann::json j = ReadJsonObjectBody(res, reader, 16 * 1024, "an upload request");
  for (const auto& [key, value] : j.items()) {
    if (key != "size" && key != "filename" && key != "kind") {
      throw ApiError(400, "bad_request", fmt::format("unknown field \"{}\" (size, filename, kind)", key));
    }
  }
  api::UploadKind kind = api::UploadKind::kFile;
  if (j.contains("kind")) {
    const std::string text = j["kind"].is_string() ? j["kind"].get<std::string>() : j["kind"].dump();
    if (text == "images") {
      kind = api::UploadKind::kImages;
    } else if (text != "file") {
      throw ApiError(400, "bad_request", fmt::format("kind must be \"file\" or \"images\", got {}", text));
    }
  }
  if (!j.contains("size") || !j["size"].is_number_integer()) {
    throw ApiError(400, "bad_request",
                   "size (the whole file's length in bytes, or the sum of an image set's, an integer) is required");
  }
  if (j.contains("filename") && !j["filename"].is_string()) {
    throw ApiError(400, "bad_request", "filename must be a string");
  }
  const api::UploadSession session =
      ctx.uploads.Create(j["size"].get<std::int64_t>(), j.value("filename", std::string()), kind);
  res.set_header("Location", "/api/v1/uploads/" + session.id);
  SendSession(ctx, res, 201, session);
}

void HandleGetUpload(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  SendSession(ctx, res, 200, ctx.uploads.Get(JobIdParam(req)));
}

void HandleDeleteUpload(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  ctx.uploads.Remove(JobIdParam(req));
  res.status = 204;
}

void HandleAppendUpload(Context& ctx, const httplib::Request& req, httplib::Response& res,
                        const httplib::ContentReader& reader) {
  const std::string id = JobIdParam(req);
  std::optional<UploadSlot> slot;
  std::optional<api::UploadStore::Appender> appender;
  try {
    const std::string content_type = req.get_header_value("Content-Type");
    const std::string media_type = content_type.substr(0, content_type.find(';'));
    if (media_type != "application/offset+octet-stream" && media_type != "application/octet-stream") {
      throw ApiError(415, "unsupported_media_type",
                     fmt::format("send the bytes as application/offset+octet-stream or application/octet-stream, "
                                 "not \"{}\"",
                                 content_type));
    }
    const std::int64_t offset = RequestOffset(req);
    slot.emplace(ctx);  // 503 beyond max_concurrent_uploads
    appender.emplace(ctx.uploads.Append(id, offset));  // 409 unless the session takes bytes at `offset`
    const api::UploadSession session = ctx.uploads.Get(id);
    const auto declared = req.get_header_value<std::uint64_t>("Content-Length");
    if (declared > static_cast<std::uint64_t>(session.size - offset)) {
      throw ApiError(413, "payload_too_large",
                     fmt::format("{} bytes from offset {} go past the upload's size of {} bytes; nothing was stored",
                                 declared, offset, session.size));
    }
  } catch (const ApiError& e) {
    appender.reset();
    if (e.status() == 409 || e.status() == 413) AddOffsetHeader(ctx, id, res);
    DrainRejectedBody(req, res, reader);
    throw;
  }
  const bool read_ok = reader([&](const char* data, std::size_t size) { return appender->Write(data, size); });
  const bool too_large = appender->too_large();
  const api::UploadSession session = appender->Finish();  // durable, whatever happened
  appender.reset();
  res.set_header(kOffsetHeader, std::to_string(session.offset));
  if (too_large) {
    res.set_header("Connection", "close");
    throw ApiError(413, "payload_too_large",
                   fmt::format("the body goes past the upload's size of {} bytes; the bytes up to it were kept",
                               session.size));
  }
  if (!read_ok) {
    res.set_header("Connection", "close");
    throw ApiError(400, "bad_upload",
                   fmt::format("the body could not be read completely; {} bytes are kept, resume from there",
                               session.offset));
  }
  SendSession(ctx, res, 200, session);
}

void HandlePutUploadImage(Context& ctx, const httplib::Request& req, httplib::Response& res,
                          const httplib::ContentReader& reader) {
  const std::string id = JobIdParam(req);
  const std::string name = req.matches.size() > 2 ? std::string(req.matches[2]) : std::string();
  std::optional<UploadSlot> slot;
  std::optional<api::UploadStore::ImageWriter> writer;
  try {
    const std::string content_type = req.get_header_value("Content-Type");
    const std::string media_type = content_type.substr(0, content_type.find(';'));
    if (media_type.rfind("image/", 0) != 0 && media_type != "application/octet-stream") {
      throw ApiError(415, "unsupported_media_type",
                     fmt::format("send the photo as image/* or application/octet-stream, not \"{}\"", content_type));
    }
    if (!req.has_header("Content-Length") || req.get_header_value("Transfer-Encoding") == "chunked") {
      throw ApiError(411, "length_required", "send each photo with a Content-Length (not chunked)");
    }
    const auto length = req.get_header_value<std::uint64_t>("Content-Length");
    slot.emplace(ctx);  // 503 beyond max_concurrent_uploads
    writer.emplace(ctx.uploads.PutImage(id, name, static_cast<std::int64_t>(length)));
  } catch (const ApiError&) {
    writer.reset();
    DrainRejectedBody(req, res, reader);
    throw;
  }
  const bool read_ok = reader([&](const char* data, std::size_t size) { return writer->Write(data, size); });
  if (!read_ok || writer->too_large()) res.set_header("Connection", "close");
  const api::UploadSession session = writer->Finish();  // stores it only when every byte arrived
  writer.reset();
  SendSession(ctx, res, 200, session, /*list_images=*/false);
}

}  // namespace glam::server
