#include "tools/synth/ground_truth_writer.h"

#include <fstream>

#include "engine/core/error.h"

namespace glam::synth {

void WriteJson(const nlohmann::json& json, const std::filesystem::path& path) {
  std::ofstream out(path);
  out << json.dump(2) << "\n";
  if (!out) throw EnvironmentError("cannot write " + path.string());
}

}  // namespace glam::synth
