// DTOs <-> JSON for the REST API: the job JSON of docs/architecture.md (Contracts), the
// progress object, and the options a client may send with an upload. Everything a client
// sends is validated here, with messages that name the offending field (they become HTTP 400
// bodies verbatim).
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "api/job.h"
#include "engine/core/camera.h"
#include "engine/pipeline/mapping_options.h"
#include "engine/pipeline/progress.h"

namespace glam::api {

// What a client may set per job. Unset fields keep the engine defaults.
struct JobOptions {
  std::string name;                         // display name; default: the upload's file name
  std::optional<int> stride;                // use every N-th frame
  std::optional<double> focal;              // focal length in pixels at original resolution
  std::optional<Intrinsics> intrinsics;     // full calibration (intrinsics.json format)
  std::optional<int> keyframes_per_submap;  // submap size
  std::optional<int> max_image_size;        // processing long side (px), 0 = no downscale
  std::optional<int> detect_every;          // SIFT on every N-th frame (1 = every frame, 0 = auto)
  // Automatic schedule: stretch the time between detections up to this where the image moves
  // slowly (`glam map --detect-max-seconds`; 0 = one detection per 0.2 s, the default).
  std::optional<double> detect_max_seconds;
  // Keep the lens' radial distortion k1 as it is (0, or the k1 of `intrinsics`, which is
  // never re-estimated) instead of estimating it (`glam map --fixed-k1`).
  std::optional<bool> fixed_k1;
  // Half width (seconds) of the camera-centre smoothing (`glam map --smooth-window`; 0 = the
  // per-frame PnP poses).
  std::optional<double> smooth_window_s;
  // Photo jobs: map the photos in name order instead of their EXIF capture order (`glam map
  // --name-order`).
  std::optional<bool> name_order;
  // With `intrinsics`: refine their focal length in bundle adjustment instead of keeping it
  // fixed (`glam map --refine-focal`; for a focal from EXIF or a data sheet). Without
  // intrinsics the focal is always estimated, so the option changes nothing there.
  std::optional<bool> refine_focal;
  // SIFT features per frame (`glam map --max-features`); default 2000 for videos, 8000 for
  // photo jobs (kPhotoFolderMaxFeatures).
  std::optional<int> max_features;
  // The end-of-run global refinement runs on maps with at most this many keyframes (`glam map
  // --global-refinement-keyframes`; default 400, 0 = never: rigid submaps). At most
  // kMaxGlobalRefinementKeyframes: the joint adjustment's memory and time grow with it.
  std::optional<int> global_refinement_keyframes;
  // The camera's rolling-shutter readout time in milliseconds, first to last image row (`glam
  // map --rolling-shutter-ms`; default 0: a global shutter). 0-100, or estimated
  // (rolling_shutter_auto; the JSON value "auto").
  std::optional<double> rolling_shutter_ms;
  bool rolling_shutter_auto = false;
  // At most this often (seconds) the submap being built is written as a provisional tile for
  // viewers (`glam map --preview-interval`; default 1, 0 = off; at most 60).
  std::optional<double> preview_interval_s;
};

// Upper bound of JobOptions::global_refinement_keyframes. Measured at 334 keyframes (2000
// frames): 10 s and +250 MB; 1000 would be roughly 3x the memory and 5x the time, once per job.
inline constexpr int kMaxGlobalRefinementKeyframes = 1000;

// Accepts an object with the keys name, stride, focal, intrinsics, keyframes_per_submap,
// max_image_size, detect_every, detect_max_seconds, fixed_k1, smooth_window_s, name_order, refine_focal,
// max_features, global_refinement_keyframes, rolling_shutter_ms, preview_interval_s (all optional). Throws InputError naming the key
// for unknown keys, wrong types or out-of-range values (the resulting MappingOptions are
// Check()ed as well).
JobOptions ParseJobOptions(const nlohmann::json& j);
// Parses text as JSON first (InputError "options: malformed JSON ...").
JobOptions ParseJobOptionsText(const std::string& text);
nlohmann::json ToJson(const JobOptions& options);

// Engine options for a job (defaults + the job's options). Throws InputError.
MappingOptions ToMappingOptions(const JobOptions& options);

nlohmann::json ProgressToJson(const MappingProgress& progress);
// Lenient: missing fields keep their defaults (the store wrote the JSON itself).
MappingProgress ProgressFromJson(const nlohmann::json& j);

// RFC 3339 UTC with milliseconds, e.g. "2026-11-23T22:57:33.120Z".
std::string FormatTimestamp(std::int64_t epoch_ms);

// The job JSON. `api_base` is the path prefix of the REST API ("/api/v1"); urls are
// absolute paths under it.
nlohmann::json JobToJson(const Job& job, const std::string& api_base = "/api/v1");

// {"error": {"code": code, "message": message}}
nlohmann::json ErrorJson(const std::string& code, const std::string& message);

}  // namespace glam::api
