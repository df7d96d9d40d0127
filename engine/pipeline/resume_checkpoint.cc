#include "engine/pipeline/resume_checkpoint.h"

#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/core/atomic_file.h"
#include "engine/core/error.h"

namespace glam {

void WriteCheckpoint(const std::filesystem::path& out_dir, const ResumeCheckpoint& c) {
  nlohmann::json json = {{"next_submap_id", c.next_submap_id},
                               {"resume_frame", c.resume_frame},
                               {"focal_px", c.focal},
                               {"focal_held", c.focal_held},
                               {"k1", c.k1},
                               {"k1_held", c.k1_held},
                               {"input", c.input},
                               {"processing_size", {c.processing_width, c.processing_height}},
                               {"run_id", c.run_id},
                               {"photos_reordered_by_time", c.photos_reordered_by_time}};
  if (c.readout_ms) json["rolling_shutter_readout_ms"] = *c.readout_ms;
  WriteFileAtomically(out_dir / kCheckpointFile, json.dump(2) + "\n");
}

std::optional<ResumeCheckpoint> ReadCheckpoint(const std::filesystem::path& out_dir) {
  const std::filesystem::path path = out_dir / kCheckpointFile;
  std::ifstream in(path);
  if (!in) return std::nullopt;
  try {
    const nlohmann::json json = nlohmann::json::parse(in);
    ResumeCheckpoint c;
    c.next_submap_id = json.at("next_submap_id").get<std::uint32_t>();
    c.resume_frame = json.at("resume_frame").get<std::int64_t>();
    c.focal = json.at("focal_px").get<double>();
    c.focal_held = json.value("focal_held", false);  // absent in checkpoints written before it existed
    c.k1 = json.value("k1", 0.0);  // likewise
    c.k1_held = json.value("k1_held", false);
    c.input = json.at("input").get<std::string>();
    c.processing_width = json.at("processing_size").at(0).get<int>();
    c.processing_height = json.at("processing_size").at(1).get<int>();
    c.run_id = json.value("run_id", std::string());
    c.photos_reordered_by_time = json.value("photos_reordered_by_time", std::int64_t{0});
    if (json.contains("rolling_shutter_readout_ms")) c.readout_ms = json.at("rolling_shutter_readout_ms").get<double>();
    if (c.resume_frame < 0 || !(c.focal > 0)) throw InputError("values out of range");
    return c;
  } catch (const std::exception& e) {
    throw InputError(fmt::format("{}: not a valid checkpoint ({})", path.string(), e.what()));
  }
}

}  // namespace glam
