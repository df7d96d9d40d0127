#include "engine/pipeline/mapping_report.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

namespace glam {
namespace {

// Unset optional measures are null in report.json.
nlohmann::json NullIfUnset(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json();
}

nlohmann::json GlobalRefinementJson(const GlobalRefinementSummary& r) {
  return {{"ran", r.ran},
          {"applied", r.applied},
          {"reason", r.reason},
          {"submaps", r.submaps},
          {"keyframes", r.keyframes},
          {"shared_keyframes", r.shared_keyframes},
          {"points", r.landmarks},
          {"joined_points", r.joined_landmarks},
          {"split_points", r.split_landmarks},
          {"observations", r.observations},
          {"initial_rms_px", r.initial_rms_pixels},
          {"final_rms_px", r.final_rms_pixels},
          {"max_camera_shift", r.max_camera_shift},
          {"iterations", r.iterations},
          {"seconds", r.seconds}};
}

// Per submap timings plus the summary a user looks for first: does thread 2 keep up?
nlohmann::json AlignmentJson(const std::vector<SubmapAlignmentTiming>& timings) {
  nlohmann::json per_submap = nlohmann::json::array();
  double total = 0, worst = 0;
  for (const SubmapAlignmentTiming& t : timings) {
    per_submap.push_back({{"submap", t.submap},
                          {"candidates", t.candidates},
                          {"edges", t.edges},
                          {"retrieval_s", t.retrieval_s},
                          {"verification_s", t.verification_s},
                          {"optimization_s", t.optimization_s},
                          {"total_s", t.total_s}});
    total += t.total_s;
    worst = std::max(worst, t.total_s);
  }
  const double mean = timings.empty() ? 0.0 : total / static_cast<double>(timings.size());
  return {{"mean_latency_s", mean}, {"max_latency_s", worst}, {"per_submap", per_submap}};
}

// The fields of one GPS fit (ok or not).
nlohmann::json FitJson(const GeoreferenceResult& g, const char* scale_name) {
  nlohmann::json j = {{"ok", g.ok}};
  if (!g.ok) {
    j["reason"] = g.reason;
    return j;
  }
  j["fit"] = g.full ? "similarity" : "yaw_scale_offset";
  j[scale_name] = g.enu_from_world.scale();
  j["samples_matched"] = g.samples_matched;
  j["samples_used"] = g.samples_used;
  j["rms_m"] = g.rms_m;
  j["extent_m"] = g.extent_m;
  return j;
}

// null without a GPS track; otherwise whether and how the map was put in metres, ENU, and
// which disconnected parts the GPS placed in it.
nlohmann::json GeoreferenceJson(const std::string& track, const GeoreferenceResult& g,
                                const std::vector<GpsPlacedPart>& parts) {
  if (track.empty()) return nullptr;
  nlohmann::json j = FitJson(g, "metres_per_map_unit");
  j["gps_track"] = track;
  if (!g.ok) return j;
  j["frame"] = "ENU";
  j["origin"] = {{"latitude", g.origin.latitude_deg},
                 {"longitude", g.origin.longitude_deg},
                 {"altitude", g.origin.altitude_m}};
  nlohmann::json placed = nlohmann::json::array();
  for (const GpsPlacedPart& part : parts) {
    nlohmann::json p = FitJson(part.fit, "metres_per_part_unit");
    p["submaps"] = part.submaps;
    p["first_frame"] = part.first_frame;
    p["last_frame"] = part.last_frame;
    placed.push_back(std::move(p));
  }
  j["parts"] = std::move(placed);
  return j;
}

nlohmann::json PartsJson(const std::vector<PartExport>& parts) {
  nlohmann::json out = nlohmann::json::array();
  for (const PartExport& part : parts) {
    out.push_back({{"part", part.number},
                   {"directory", "parts/" + std::to_string(part.number)},
                   {"submaps", part.submaps},
                   {"first_frame", part.first_frame},
                   {"last_frame", part.last_frame},
                   {"frames_posed", part.frames_posed},
                   {"points", part.points}});
  }
  return out;
}

}  // namespace

std::vector<std::string> Diagnose(const MappingReport& r, int min_features) {
  std::vector<std::string> warnings;
  if (r.input_ended_early) {
    warnings.push_back(fmt::format(
        "the input ended after {} frames were read although {} were expected: the file is "
        "truncated or corrupt; only the frames before the damage were mapped",
        r.frames_decoded, r.frames_total));
  }
  if (r.frames_dropped > 0) {
    warnings.push_back(fmt::format(
        "{} frames of the live stream were dropped because mapping was slower than the stream "
        "({} mapped): lower --max-image-size or the stream's frame rate, or record the flight and map "
        "the file",
        r.frames_dropped, r.frames_decoded));
  }
  if (r.frames_without_features == r.frames_decoded) {
    warnings.push_back(fmt::format(
        "no features in any of the {} frames (fewer than {} each): the video is black, uniform "
        "or textureless, so nothing can be mapped",
        r.frames_decoded, min_features));
    return warnings;
  }
  if (r.frames_without_features * 10 >= r.frames_decoded) {
    warnings.push_back(fmt::format(
        "no features in {} of {} frames (fewer than {} each): dark, uniform or blurred frames "
        "cannot be posed",
        r.frames_without_features, r.frames_decoded, min_features));
  }
  std::int64_t frames_in_parts = 0;
  for (const PartExport& part : r.parts) frames_in_parts += part.frames_posed;
  if (r.submaps == 0 && r.keyframes > 0) {
    warnings.push_back(fmt::format(
        "none of the {} frames could be posed: maps were started but none reached 3 keyframes "
        "(too short a clip or too little motion; tracking lost {} times)",
        r.frames_decoded, r.tracking_losses));
  } else if (r.submaps == 0) {
    warnings.push_back(fmt::format(
        "none of the {} frames could be posed: no pair of frames had enough parallax to start a "
        "map (a static or hovering camera, or too short a clip), or consecutive frames do not "
        "overlap",
        r.frames_decoded));
  } else if (std::max<std::int64_t>(0, r.frames_unposed - frames_in_parts) * 10 >= r.frames_decoded) {
    warnings.push_back(fmt::format("{} of {} frames could not be posed (see trajectory.tum{})",
                                   std::max<std::int64_t>(0, r.frames_unposed - frames_in_parts),
                                   r.frames_decoded, r.parts.empty() ? "" : " and parts/"));
  }
  if (!r.parts.empty()) {
    warnings.push_back(fmt::format(
        "{} part{} of the flight ({} frames) could not be linked to the map (no overlap with "
        "it was found, e.g. after a tracking loss over water, a hard cut or a fast turn), so "
        "trajectory.tum and points.ply lack {}: {} written on {} own in parts/<n>/, in {} own "
        "frame and scale",
        r.parts.size(), r.parts.size() == 1 ? "" : "s", frames_in_parts,
        r.parts.size() == 1 ? "it" : "them", r.parts.size() == 1 ? "it is" : "they are",
        r.parts.size() == 1 ? "its" : "their", r.parts.size() == 1 ? "its" : "their"));
  }
  for (const GpsPlacedPart& part : r.georeferenced_parts) {
    if (!part.fit.ok) continue;
    warnings.push_back(fmt::format(
        "frames {}-{} could not be linked to the rest of the map by the images; the GPS placed "
        "them in it (fit rms {:.1f} m), so where they sit relative to the rest is only as "
        "accurate as the GPS",
        part.first_frame, part.last_frame, part.fit.rms_m));
  }
  // Not determined (every profile flat) is no warning: a global-shutter flight over low relief
  // or at low image speed gives flat profiles too (the loop test clip), and there a correction
  // would not matter. report.json rolling_shutter.determined says so.
  if (r.rolling_shutter_estimated && r.rolling_shutter_ms > 0 && r.rolling_shutter_decided_at_submap > 0) {
    warnings.push_back(fmt::format(
        "the rolling-shutter readout ({:.1f} ms) could only be estimated on submap {}, so the {} "
        "submap{} before it {} mapped uncorrected; for the best map, run again with the readout "
        "given (glam map --rolling-shutter-ms {:.0f}, or the job option rolling_shutter_ms)",
        r.rolling_shutter_ms, r.rolling_shutter_decided_at_submap, r.rolling_shutter_decided_at_submap,
        r.rolling_shutter_decided_at_submap == 1 ? "" : "s", r.rolling_shutter_decided_at_submap == 1 ? "was" : "were",
        r.rolling_shutter_ms));
  }
  const double focal_change =
      r.free_focal_original && r.focal_original > 0 ? *r.free_focal_original / r.focal_original - 1.0 : 0.0;
  if (std::abs(focal_change) > kFixedFocalWarningFraction &&
      r.free_focal_rms_gain.value_or(1.0) >= kFixedFocalMinRmsGain) {
    warnings.push_back(fmt::format(
        "the fixed focal length ({:.1f} px) looks {:+.0f} % off: let free, the first submap's "
        "bundle adjustment moves it to {:.1f} px. Unless it comes from a calibration, map again "
        "with the focal refined (glam map --refine-focal, or pass it as --focal / the job option "
        "`focal` instead of intrinsics)",
        r.focal_original, 100.0 * focal_change, *r.free_focal_original));
  }
  if (r.focal_held) {
    warnings.push_back(fmt::format(
        "the images do not determine the focal length (typical of a camera looking straight down "
        "at flat ground), so the initial {:.1f} px was kept: heights and distances to the ground "
        "are off by as much as it is. For an accurate map pass the camera's focal (glam map "
        "--focal or --intrinsics, or the job option `focal`)",
        r.focal_original));
  }
  if (!r.gps_track.empty() && !r.georeference.ok) {
    warnings.push_back(fmt::format(
        "the GPS track {} was not used ({}), so the map is not georeferenced: its scale and "
        "heading are the first submap's",
        r.gps_track, r.georeference.reason));
  }
  return warnings;
}

namespace {

// [{"readout_ms": ..., "rms_px": ...}, ...]
nlohmann::json RollingShutterProfileJson(const std::vector<std::pair<double, double>>& profile) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [ms, rms] : profile) out.push_back({{"readout_ms", ms}, {"rms_px", rms}});
  return out;
}

}  // namespace

nlohmann::json MappingReport::ToJson() const {
  return {{"input", input},
          {"frames_total", frames_total},
          {"frames_decoded", frames_decoded},
          {"frames_posed", frames_posed},
          {"frames_unposed", frames_unposed},
          {"frames_without_features", frames_without_features},
          {"frames_detected", frames_detected},
          {"detection_interval", detection_interval},
          {"max_detection_interval", max_detection_interval},
          {"rolling_shutter",
           {{"readout_ms", rolling_shutter_ms},
            {"estimated", rolling_shutter_estimated},
            {"determined", rolling_shutter_determined},
            {"decided_at_submap", rolling_shutter_decided_at_submap},
            {"profile", RollingShutterProfileJson(rolling_shutter_profile)},
            {"mean_shift_px", rolling_shutter_mean_shift_px},
            {"max_shift_px", rolling_shutter_max_shift_px}}},
          {"keyframes", keyframes},
          {"submaps", submaps},
          {"submaps_discarded", submaps_discarded},
          {"disconnected_submaps", disconnected_submaps},
          {"parts", PartsJson(parts)},
          {"points", points},
          {"tracking_losses", tracking_losses},
          {"frames_matched_globally", frames_matched_globally},
          {"frames_rotation_only", frames_rotation_only},
          {"moving_landmarks_removed", moving_landmarks_removed},
          {"submap_rebuilds", submap_rebuilds},
          {"bootstrap_twin_checks", bootstrap_twin_checks},
          {"bootstrap_twins_kept", bootstrap_twins_kept},
          {"resumed_from_frame", resumed_from_frame},
          {"revision", revision},
          {"graph", {{"edges", graph_edges}, {"retrieved_edges", retrieved_edges}, {"landmarks", graph_landmarks}}},
          {"alignment", AlignmentJson(alignment)},
          {"global_refinement", GlobalRefinementJson(global_refinement)},
          {"initial_focal_px", initial_focal},
          {"sift_max_features", sift_max_features},
          {"focal_px", focal},
          {"focal_original_px", focal_original},
          {"free_focal_original_px", NullIfUnset(free_focal_original)},
          {"free_focal_rms_gain", NullIfUnset(free_focal_rms_gain)},
          {"focal_held", focal_held},
          {"focal_profile_rms_increase", NullIfUnset(focal_profile_rms_increase)},
          {"k1", k1},
          {"k1_estimated", k1_estimated},
          {"k1_held", k1_held},
          {"k1_profile_rms_increase", NullIfUnset(k1_profile_rms_increase)},
          {"fps", fps},
          {"processing_fps", processing_fps},
          {"processing_size", {processing_width, processing_height}},
          {"input_ended_early", input_ended_early},
          {"input_is_stream", input_is_stream},
          {"frames_dropped", frames_dropped},
          {"photos_reordered_by_time", photos_reordered_by_time},
          {"georeference", GeoreferenceJson(gps_track, georeference, georeferenced_parts)},
          {"warnings", warnings},
          {"timings_s",
           {{"decode_and_features", timings.decode_and_features_s},
            {"builder", timings.builder_s},
            {"bundle_adjustment", timings.bundle_adjust_s},
            {"alignment", timings.alignment_s},
            {"global_refinement", timings.global_refinement_s},
            {"writing", timings.writing_s},
            {"tiles", timings.tiles_s},
            {"total", timings.total_s}}}};
}

}  // namespace glam
