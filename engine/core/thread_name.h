// Names the calling thread, so `top -H`, `ps -L`, gdb and /proc/PID/task/*/comm tell a
// mapping run's stages apart (decoding + KLT, SIFT helpers, thread 2, job workers). The
// scale benchmark reads these names to attribute CPU time to stages: which stage's cost grows
// with the flight is what decides whether a 100,000-frame video slows down.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace glam {

// Linux keeps at most 15 characters of a thread's name; longer names are cut to that.
inline constexpr std::size_t kMaxThreadNameLength = 15;

// Best effort: a failure (no such facility) leaves the name unchanged and is not an error.
void NameCurrentThread(std::string_view name);

// The calling thread's name as the system keeps it ("" where names are not supported).
std::string CurrentThreadName();

}  // namespace glam
