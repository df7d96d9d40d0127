// GET /api/v1/jobs/{id}/events: Server-Sent Events. Every event carries `id:` (monotonic per
// job), so a client reconnecting with Last-Event-ID (header, or ?lastEventId= for clients that
// cannot set headers) gets the persisted state / submap / revision events it missed; progress
// is never replayed, only its latest value is sent. The stream of a finished job ends after
// the final state event. Each open stream occupies one HTTP worker, hence the client limit.
#include <memory>

#include <fmt/format.h>

#include "api/api_error.h"
#include "api/ids.h"
#include "engine/core/logging.h"
#include "server/http_context.h"

namespace glam::server {
namespace {

std::int64_t LastEventId(const httplib::Request& req) {
  std::string text;
  if (req.has_header("Last-Event-ID")) {
    text = req.get_header_value("Last-Event-ID");
  } else if (req.has_param("lastEventId")) {
    text = req.get_param_value("lastEventId");
  } else {
    return 0;
  }
  long long value = 0;
  if (!api::ParseNonNegativeInt(text, &value)) {
    throw api::ApiError(400, "bad_request",
                        fmt::format("Last-Event-ID must be a non-negative integer, got \"{}\"", text));
  }
  return value;
}

struct StreamState {
  std::int64_t after = 0;
  bool started = false;
};

}  // namespace

void HandleEvents(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  const std::string id = JobIdParam(req);
  ctx.service.Get(id);  // 400 / 404 before the stream starts
  const std::int64_t after = LastEventId(req);
  if (++ctx.sse_clients > ctx.options.max_sse_clients) {
    --ctx.sse_clients;
    throw api::ApiError(503, "too_many_streams",
                        fmt::format("{} event streams are open (limit {}); poll GET /api/v1/jobs/{} "
                                    "instead or try again later",
                                    ctx.options.max_sse_clients, ctx.options.max_sse_clients, id));
  }
  auto state = std::make_shared<StreamState>();
  state->after = after;
  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");
  Context* context = &ctx;
  res.set_chunked_content_provider(
      "text/event-stream",
      [context, id, state](std::size_t /*offset*/, httplib::DataSink& sink) {
        if (!state->started) {
          state->started = true;
          const std::string hello = "retry: 3000\n: glam event stream\n\n";
          if (!sink.write(hello.data(), hello.size())) return false;
        }
        const api::EventBatch batch =
            context->service.WaitForEvents(id, state->after, context->options.sse_keepalive);
        if (batch.gone) {
          sink.done();
          return true;
        }
        std::string out;
        for (const api::JobEvent& event : batch.events) {
          out += fmt::format("id: {}\nevent: {}\ndata: {}\n\n", event.id, event.type, event.data.dump());
          state->after = event.id;
        }
        if (out.empty() && !batch.finished) out = ": keep-alive\n\n";
        if (!out.empty() && !sink.write(out.data(), out.size())) return false;
        if (batch.finished) sink.done();
        return true;
      },
      [context](bool /*success*/) { --context->sse_clients; });
}

}  // namespace glam::server
