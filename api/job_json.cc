#include "api/job_json.h"

#include <ctime>
#include <set>

#include <fmt/format.h>

#include "api/stream_url.h"
#include "engine/video/stream_source.h"
#include "engine/core/error.h"

namespace glam::api {
namespace {

using nlohmann::json;

// Bounds of options.max_features: fewer than ~100 features cannot track a frame; more than
// 50,000 per frame would only spend memory and time (8000 is the photo-job default).
constexpr int kMinMaxFeatures = 100;
constexpr int kMaxMaxFeatures = 50000;

int GetInt(const json& j, const char* key) {
  if (!j.is_number_integer()) {
    throw InputError(fmt::format("options.{} must be an integer, got {}", key, j.dump()));
  }
  const auto v = j.get<long long>();
  if (v < -1000000000LL || v > 1000000000LL) {
    throw InputError(fmt::format("options.{} is out of range: {}", key, v));
  }
  return static_cast<int>(v);
}

bool GetBool(const json& j, const char* key) {
  if (!j.is_boolean()) throw InputError(fmt::format("options.{} must be true or false, got {}", key, j.dump()));
  return j.get<bool>();
}

double GetNumber(const json& j, const char* key) {
  if (!j.is_number()) {
    throw InputError(fmt::format("options.{} must be a number, got {}", key, j.dump()));
  }
  return j.get<double>();
}

Intrinsics ParseIntrinsics(const json& j) {
  if (!j.is_object()) {
    throw InputError(fmt::format("options.intrinsics must be an object, got {}", j.dump()));
  }
  static const std::set<std::string> kKnown = {"model", "width", "height", "fx", "fy",
                                               "cx",    "cy",    "k1",     "k2"};
  for (const auto& [key, value] : j.items()) {
    if (kKnown.count(key) == 0) {
      throw InputError(fmt::format("options.intrinsics: unknown field \"{}\"", key));
    }
  }
  auto required = [&](const char* key) -> const json& {
    const auto it = j.find(key);
    if (it == j.end()) {
      throw InputError(fmt::format("options.intrinsics: missing field \"{}\"", key));
    }
    return *it;
  };
  Intrinsics k;
  const json& model = required("model");
  if (!model.is_string()) throw InputError("options.intrinsics.model must be a string");
  k.model = model.get<std::string>();
  k.width = GetInt(required("width"), "intrinsics.width");
  k.height = GetInt(required("height"), "intrinsics.height");
  k.fx = GetNumber(required("fx"), "intrinsics.fx");
  k.fy = GetNumber(required("fy"), "intrinsics.fy");
  k.cx = GetNumber(required("cx"), "intrinsics.cx");
  k.cy = GetNumber(required("cy"), "intrinsics.cy");
  if (j.contains("k1")) k.k1 = GetNumber(j["k1"], "intrinsics.k1");
  if (j.contains("k2")) k.k2 = GetNumber(j["k2"], "intrinsics.k2");
  k.Check();
  return k;
}

}  // namespace

JobOptions ParseJobOptions(const json& j) {
  if (!j.is_object()) throw InputError(fmt::format("options must be a JSON object, got {}", j.dump()));
  JobOptions o;
  for (const auto& [key, value] : j.items()) {
    if (value.is_null()) continue;
    if (key == "name") {
      if (!value.is_string()) throw InputError("options.name must be a string");
      o.name = value.get<std::string>();
      if (o.name.size() > 200) throw InputError("options.name is longer than 200 characters");
    } else if (key == "stride") {
      o.stride = GetInt(value, "stride");
    } else if (key == "focal") {
      o.focal = GetNumber(value, "focal");
      if (!(*o.focal > 0)) throw InputError(fmt::format("options.focal must be > 0, got {}", *o.focal));
    } else if (key == "intrinsics") {
      o.intrinsics = ParseIntrinsics(value);
    } else if (key == "keyframes_per_submap") {
      o.keyframes_per_submap = GetInt(value, "keyframes_per_submap");
    } else if (key == "max_image_size") {
      o.max_image_size = GetInt(value, "max_image_size");
    } else if (key == "detect_every") {
      o.detect_every = GetInt(value, "detect_every");
      if (*o.detect_every < 0 || *o.detect_every > 1000) {
        throw InputError(fmt::format("options.detect_every must be in [0, 1000] (0 = automatic), got {}",
                                     *o.detect_every));
      }
    } else if (key == "detect_max_seconds") {
      o.detect_max_seconds = GetNumber(value, "detect_max_seconds");
      if (!(*o.detect_max_seconds >= 0 && *o.detect_max_seconds <= 10)) {
        throw InputError(fmt::format(
            "options.detect_max_seconds must be in [0, 10] seconds (0 = one detection per 0.2 s), got {}",
            *o.detect_max_seconds));
      }
    } else if (key == "fixed_k1") {
      o.fixed_k1 = GetBool(value, "fixed_k1");
    } else if (key == "name_order") {
      o.name_order = GetBool(value, "name_order");
    } else if (key == "refine_focal") {
      o.refine_focal = GetBool(value, "refine_focal");
    } else if (key == "max_features") {
      o.max_features = GetInt(value, "max_features");
      if (*o.max_features < kMinMaxFeatures || *o.max_features > kMaxMaxFeatures) {
        throw InputError(fmt::format("options.max_features must be in [{}, {}], got {}", kMinMaxFeatures,
                                     kMaxMaxFeatures, *o.max_features));
      }
    } else if (key == "global_refinement_keyframes") {
      o.global_refinement_keyframes = GetInt(value, "global_refinement_keyframes");
      if (*o.global_refinement_keyframes < 0 || *o.global_refinement_keyframes > kMaxGlobalRefinementKeyframes) {
        throw InputError(fmt::format("options.global_refinement_keyframes must be in [0, {}] (0 = never), got {}",
                                     kMaxGlobalRefinementKeyframes, *o.global_refinement_keyframes));
      }
    } else if (key == "rolling_shutter_ms" && value.is_string()) {
      if (value.get<std::string>() != "auto") {
        throw InputError(fmt::format(
            "options.rolling_shutter_ms must be a number of milliseconds or \"auto\", got {}", value.dump()));
      }
      o.rolling_shutter_auto = true;
      o.rolling_shutter_ms.reset();
    } else if (key == "rolling_shutter_ms") {
      o.rolling_shutter_ms = GetNumber(value, "rolling_shutter_ms");
      o.rolling_shutter_auto = false;
      if (!(*o.rolling_shutter_ms >= 0 && *o.rolling_shutter_ms <= 100)) {
        throw InputError(fmt::format(
            "options.rolling_shutter_ms must be in [0, 100] milliseconds (0 = global shutter), got {}",
            *o.rolling_shutter_ms));
      }
    } else if (key == "preview_interval_s") {
      o.preview_interval_s = GetNumber(value, "preview_interval_s");
      if (!(*o.preview_interval_s >= 0 && *o.preview_interval_s <= 60)) {
        throw InputError(fmt::format("options.preview_interval_s must be in [0, 60] seconds (0 = off), got {}",
                                     *o.preview_interval_s));
      }
    } else if (key == "smooth_window_s") {
      o.smooth_window_s = GetNumber(value, "smooth_window_s");
      if (!(*o.smooth_window_s >= 0 && *o.smooth_window_s <= 5)) {
        throw InputError(fmt::format("options.smooth_window_s must be in [0, 5] seconds (0 = off), got {}",
                                     *o.smooth_window_s));
      }
    } else {
      throw InputError(fmt::format(
          "options: unknown key \"{}\" (known: name, stride, focal, intrinsics, "
          "keyframes_per_submap, max_image_size, detect_every, detect_max_seconds, fixed_k1, smooth_window_s, "
          "name_order, "
          "refine_focal, max_features, global_refinement_keyframes, rolling_shutter_ms, preview_interval_s)",
          key));
    }
  }
  ToMappingOptions(o);  // range checks of the engine
  return o;
}

JobOptions ParseJobOptionsText(const std::string& text) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("options: malformed JSON: {}", e.what()));
  }
  return ParseJobOptions(j);
}

json ToJson(const JobOptions& o) {
  json j = json::object();
  if (!o.name.empty()) j["name"] = o.name;
  if (o.stride) j["stride"] = *o.stride;
  if (o.focal) j["focal"] = *o.focal;
  if (o.intrinsics) {
    const Intrinsics& k = *o.intrinsics;
    j["intrinsics"] = {{"model", k.model}, {"width", k.width}, {"height", k.height},
                       {"fx", k.fx},       {"fy", k.fy},       {"cx", k.cx},
                       {"cy", k.cy},       {"k1", k.k1},       {"k2", k.k2}};
  }
  if (o.keyframes_per_submap) j["keyframes_per_submap"] = *o.keyframes_per_submap;
  if (o.max_image_size) j["max_image_size"] = *o.max_image_size;
  if (o.detect_every) j["detect_every"] = *o.detect_every;
  if (o.detect_max_seconds) j["detect_max_seconds"] = *o.detect_max_seconds;
  if (o.fixed_k1) j["fixed_k1"] = *o.fixed_k1;
  if (o.smooth_window_s) j["smooth_window_s"] = *o.smooth_window_s;
  if (o.preview_interval_s) j["preview_interval_s"] = *o.preview_interval_s;
  if (o.name_order) j["name_order"] = *o.name_order;
  if (o.refine_focal) j["refine_focal"] = *o.refine_focal;
  if (o.max_features) j["max_features"] = *o.max_features;
  if (o.global_refinement_keyframes) j["global_refinement_keyframes"] = *o.global_refinement_keyframes;
  if (o.rolling_shutter_auto) {
    j["rolling_shutter_ms"] = "auto";
  } else if (o.rolling_shutter_ms) {
    j["rolling_shutter_ms"] = *o.rolling_shutter_ms;
  }
  return j;
}

MappingOptions ToMappingOptions(const JobOptions& o) {
  MappingOptions m;
  if (o.stride) m.source.stride = *o.stride;
  if (o.max_image_size) m.source.max_image_size = *o.max_image_size;
  if (o.intrinsics) UseCalibration(&m, *o.intrinsics);  // as `glam map --intrinsics`
  if (o.refine_focal && *o.refine_focal) m.submap.bundle_adjustment.refine_focal = true;  // --refine-focal
  if (o.max_features) m.sift.max_features = *o.max_features;
  if (o.focal) m.focal_px = *o.focal;
  if (o.keyframes_per_submap) m.submap.keyframes_per_submap = *o.keyframes_per_submap;
  if (o.detect_every) m.detection_interval = *o.detect_every;
  if (o.detect_max_seconds) m.max_detection_seconds = *o.detect_max_seconds;
  if (o.fixed_k1 && *o.fixed_k1) m.submap.bundle_adjustment.refine_k1 = false;  // as --fixed-k1
  if (o.smooth_window_s) m.submap.centre_smoothing.half_window_s = *o.smooth_window_s;
  if (o.preview_interval_s) m.preview.interval_s = *o.preview_interval_s;
  if (o.name_order && *o.name_order) m.source.photos_by_capture_time = false;  // as --name-order
  if (o.global_refinement_keyframes) m.global_refinement.max_keyframes = *o.global_refinement_keyframes;
  if (o.rolling_shutter_ms) {  // as --rolling-shutter-ms MS (0: a global shutter)
    m.rolling_shutter = RollingShutterOptions{};
    m.rolling_shutter.readout_ms = *o.rolling_shutter_ms;
  }
  if (o.rolling_shutter_auto) m.rolling_shutter = EstimatedRollingShutter();  // the default
  m.Check();
  return m;
}

json ProgressToJson(const MappingProgress& p) {
  return {{"stage", p.stage},
          {"frames_done", p.frames_done},
          {"frames_total", p.frames_total},
          {"fps", p.fps},
          {"eta_s", p.eta_s},
          {"submaps_completed", p.submaps_completed},
          {"submaps_aligned", p.submaps_aligned},
          {"keyframes", p.keyframes},
          {"points", p.points},
          {"revision", p.revision}};
}

MappingProgress ProgressFromJson(const json& j) {
  MappingProgress p;
  if (!j.is_object()) return p;
  p.stage = j.value("stage", p.stage);
  p.frames_done = j.value("frames_done", p.frames_done);
  p.frames_total = j.value("frames_total", p.frames_total);
  p.fps = j.value("fps", p.fps);
  p.eta_s = j.value("eta_s", p.eta_s);
  p.submaps_completed = j.value("submaps_completed", p.submaps_completed);
  p.submaps_aligned = j.value("submaps_aligned", p.submaps_aligned);
  p.keyframes = j.value("keyframes", p.keyframes);
  p.points = j.value("points", p.points);
  p.revision = j.value("revision", p.revision);
  return p;
}

std::string FormatTimestamp(std::int64_t epoch_ms) {
  const std::time_t seconds = static_cast<std::time_t>(epoch_ms / 1000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", tm.tm_year + 1900, tm.tm_mon + 1,
                     tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, epoch_ms % 1000);
}

json JobToJson(const Job& job, const std::string& api_base) {
  const std::string base = api_base + "/jobs/" + job.id;
  json urls = {{"self", base},
               {"events", base + "/events"},
               {"cancel", base + "/cancel"},
               {"restart", base + "/restart"},
               {"trajectory", base + "/trajectory.tum"},
               {"points", base + "/points.ply"},
               {"report", base + "/report.json"},
               {"graph", base + "/graph.json"},
               {"tileset", base + "/tileset.json"},
               {"map_glb", base + "/map.glb"},
               {"colmap_cameras", base + "/colmap/cameras.txt"},
               {"colmap_images", base + "/colmap/images.txt"},
               {"colmap_points3D", base + "/colmap/points3D.txt"},
               {"viewer", "/?job=" + job.id}};
  json parts = json::array();
  for (const json& stored : job.parts) {
    if (!stored.is_object() || !stored.contains("part") || !stored["part"].is_number_integer()) continue;
    json part = stored;
    const std::string dir = base + "/parts/" + std::to_string(stored["part"].get<int>());
    part["urls"] = {{"trajectory", dir + "/trajectory.tum"},
                    {"points", dir + "/points.ply"},
                    {"colmap_cameras", dir + "/colmap/cameras.txt"},
                    {"colmap_images", dir + "/colmap/images.txt"},
                    {"colmap_points3D", dir + "/colmap/points3D.txt"}};
    parts.push_back(std::move(part));
  }
  json input = job.input_info;
  if (input.is_object() && input.contains("stream_url") && input["stream_url"].is_string()) {
    input["stream_url"] = RedactStreamUrl(input["stream_url"].get<std::string>());
  }
  return {{"id", job.id},
          {"name", job.name},
          {"state", std::string(ToString(job.state))},
          {"error", job.error ? json(*job.error) : json(nullptr)},
          {"created_at", FormatTimestamp(job.created_ms)},
          {"updated_at", FormatTimestamp(job.updated_ms)},
          {"urls", urls},
          {"progress", ProgressToJson(job.progress)},
          {"options", job.options},
          {"input", input},
          {"warnings", job.warnings},
          {"parts", parts}};
}

json ErrorJson(const std::string& code, const std::string& message) {
  return {{"error", {{"code", code}, {"message", message}}}};
}

}  // namespace glam::api
