#include "engine/core/intrinsics_io.h"

#include <fstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/core/error.h"

namespace glam {
namespace {

using nlohmann::json;

// Reads field `name` as T; a missing field is an error unless `fallback` is given.
template <typename T>
T ReadField(const json& j, const char* name, const std::filesystem::path& path,
            const T* fallback = nullptr) {
  const auto it = j.find(name);
  if (it == j.end() || it->is_null()) {
    if (fallback != nullptr) return *fallback;
    throw InputError(fmt::format("{}: missing field \"{}\"", path.string(), name));
  }
  const bool ok = [&] {
    if constexpr (std::is_same_v<T, std::string>) return it->is_string();
    else if constexpr (std::is_integral_v<T>) return it->is_number_integer();
    else return it->is_number();
  }();
  if (!ok) {
    throw InputError(fmt::format("{}: field \"{}\" has the wrong type ({}): {}", path.string(),
                                 name, it->type_name(), it->dump()));
  }
  return it->get<T>();
}

}  // namespace

Intrinsics ReadIntrinsicsJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open intrinsics file {}", path.string()));
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("{}: malformed JSON: {}", path.string(), e.what()));
  }
  if (!j.is_object()) {
    throw InputError(fmt::format("{}: expected a JSON object", path.string()));
  }
  Intrinsics k;
  k.model = ReadField<std::string>(j, "model", path);
  k.width = ReadField<int>(j, "width", path);
  k.height = ReadField<int>(j, "height", path);
  k.fx = ReadField<double>(j, "fx", path);
  k.fy = ReadField<double>(j, "fy", path);
  k.cx = ReadField<double>(j, "cx", path);
  k.cy = ReadField<double>(j, "cy", path);
  const double zero = 0.0;
  k.k1 = ReadField<double>(j, "k1", path, &zero);
  k.k2 = ReadField<double>(j, "k2", path, &zero);
  try {
    k.Check();
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path.string(), e.what()));
  }
  return k;
}

void WriteIntrinsicsJson(const Intrinsics& intrinsics, const std::filesystem::path& path) {
  intrinsics.Check();
  const json j = {{"model", intrinsics.model}, {"width", intrinsics.width},
                  {"height", intrinsics.height}, {"fx", intrinsics.fx},
                  {"fy", intrinsics.fy},       {"cx", intrinsics.cx},
                  {"cy", intrinsics.cy},       {"k1", intrinsics.k1},
                  {"k2", intrinsics.k2}};
  std::ofstream out(path);
  // nlohmann's dump uses max_digits10 for doubles, so the round trip is exact.
  out << j.dump(2) << '\n';
  out.flush();
  if (!out) throw EnvironmentError(fmt::format("cannot write intrinsics file {}", path.string()));
}

}  // namespace glam
