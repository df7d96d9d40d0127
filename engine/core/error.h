// Error channels used throughout GLAM (see docs/architecture.md, "Conventions"):
//   * programmer error            -> GLAM_CHECK / assert: abort with a message.
//   * bad input from a user        -> glam::InputError: becomes a clear CLI message or HTTP 4xx.
//   * environment failure (disk,   -> glam::EnvironmentError: the job fails with this message,
//     decoder, out of space)          nothing else is lost.
// Typed exceptions let the API layer map failures to status codes without string matching.
#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace glam {

// The user gave us something we cannot use (file, option, request). Message is user-facing.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Something outside the user's input failed (I/O, decoder, resources).
class EnvironmentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown by code that observed a cancellation token; not an error for the job's owner.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

[[noreturn]] void FailCheck(const char* file, int line, const char* expr, const std::string& msg);

}  // namespace glam

// Invariant checks that stay on in release builds: a violated invariant is a bug, and a
// wrong map is worse than a crash with a message.
#define GLAM_CHECK(cond, ...)                                                         \
  do {                                                                                \
    if (!(cond)) ::glam::FailCheck(__FILE__, __LINE__, #cond, ::fmt::format("" __VA_ARGS__)); \
  } while (0)
