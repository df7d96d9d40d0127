// Every component has an Options struct whose defaults come from the paper and whose
// Check() rejects nonsense with a user-facing InputError. These helpers keep Check()
// bodies to one line per field and the messages uniform ("<Options>.<field> must be ...").
#pragma once

#include <string_view>

#include <fmt/format.h>

#include "engine/core/error.h"

namespace glam {

template <typename T>
void CheckGreater(std::string_view name, T value, T bound) {
  if (!(value > bound)) throw InputError(fmt::format("{} must be > {}, got {}", name, bound, value));
}

template <typename T>
void CheckGreaterEqual(std::string_view name, T value, T bound) {
  if (!(value >= bound)) {
    throw InputError(fmt::format("{} must be >= {}, got {}", name, bound, value));
  }
}

template <typename T>
void CheckInRange(std::string_view name, T value, T lo, T hi) {
  if (!(value >= lo && value <= hi)) {
    throw InputError(fmt::format("{} must be in [{}, {}], got {}", name, lo, hi, value));
  }
}

}  // namespace glam
