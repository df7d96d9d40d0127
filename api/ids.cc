#include "api/ids.h"

#include <random>

namespace glam::api {

std::string NewJobId() {
  static constexpr char kHex[] = "0123456789abcdef";
  std::random_device device;
  std::string id(16, '0');
  for (int half = 0; half < 2; ++half) {
    std::uint32_t bits = device();
    for (int i = 0; i < 8; ++i) {
      id[half * 8 + i] = kHex[bits & 0xf];
      bits >>= 4;
    }
  }
  return id;
}

bool IsValidJobId(std::string_view id) {
  if (id.size() != 16) return false;
  for (const char c : id) {
    const bool hex = (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
    if (!hex) return false;
  }
  return true;
}

bool ParseNonNegativeInt(std::string_view text, long long* value) {
  if (text.empty() || text.size() > 18) return false;
  long long v = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  *value = v;
  return true;
}

}  // namespace glam::api
