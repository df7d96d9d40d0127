// What a mapping run did, for report.json and for the server's job record: counts, focal
// estimate, timings and, in words, what could not be mapped and why.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/alignment/submap_aligner.h"
#include "engine/alignment/global_refinement.h"
#include "engine/geo/georeference.h"
#include "engine/pipeline/georeference_map.h"
#include "engine/pipeline/map_export.h"

namespace glam {

struct MappingTimings {
  double decode_and_features_s = 0;  // decoder thread busy time (decode + SIFT + KLT)
  double builder_s = 0;              // submap builder time, including BA
  double bundle_adjust_s = 0;        // of which bundle adjustment
  double alignment_s = 0;            // thread 2 busy time (retrieval, verification, graph)
  double global_refinement_s = 0;    // the end-of-run joint bundle adjustment (map_refinement.h)
  double writing_s = 0;              // submaps, tiles and whole-map files
  double tiles_s = 0;                // of writing_s: encoding + writing the per-submap tiles
  double total_s = 0;
};

struct MappingReport {
  std::string input;
  std::int64_t frames_total = -1;  // expected after stride (container estimate)
  std::int64_t frames_decoded = 0;
  std::int64_t frames_posed = 0;
  std::int64_t frames_unposed = 0;  // decoded but absent from trajectory.tum
  // Frames with fewer SIFT features than tracking needs (SubmapOptions::min_tracking_inliers):
  // black, uniform, overexposed or badly blurred frames, which can never be posed.
  std::int64_t frames_without_features = 0;
  std::int64_t frames_detected = 0;  // frames that got SIFT (the others: KLT propagation)
  int detection_interval = 1;        // SIFT on every N-th frame (MappingOptions)
  int max_detection_interval = 1;    // the adaptive schedule's longest (= detection_interval: fixed)
  // Rolling-shutter correction (RollingShutterOptions): the readout used (0 = none) and how far
  // keypoints were moved, on average and at most (pixels).
  double rolling_shutter_ms = 0;
  // Readout estimated (auto), whether a profile determined it (else: left at 0, a flight of
  // straight legs), and the last profile's (ms, rms px).
  bool rolling_shutter_estimated = false;
  bool rolling_shutter_determined = false;
  std::vector<std::pair<double, double>> rolling_shutter_profile;
  std::int64_t rolling_shutter_decided_at_submap = 0;  // estimated: the submap that decided it
  double rolling_shutter_mean_shift_px = 0;
  double rolling_shutter_max_shift_px = 0;
  std::int64_t keyframes = 0;
  std::int64_t submaps = 0;
  std::int64_t submaps_discarded = 0;
  std::int64_t disconnected_submaps = 0;
  // Disconnected parts, each written on its own to parts/<n>/ (map_export.h).
  std::vector<PartExport> parts;
  std::int64_t points = 0;
  std::int64_t tracking_losses = 0;
  // Frames whose guided matching failed, matched against all landmarks instead.
  std::int64_t frames_matched_globally = 0;
  // Frames posed by rotation only through a hovering yaw (SubmapOptions::hover_max_speed).
  std::int64_t frames_rotation_only = 0;
  // Landmarks removed as lying on content that moves on its own (water, cloud-shadow edges;
  // SubmapOptions::moving_landmark_frames).
  std::int64_t moving_landmarks_removed = 0;
  std::int64_t submap_rebuilds = 0;  // submaps tracked again after the focal estimate moved
  // Open submaps tracked again from the other motion of a focal-dependent bootstrap, and how
  // many of those second builds were kept (SubmapOptions::bootstrap_twin_focal_step).
  std::int64_t bootstrap_twin_checks = 0;
  std::int64_t bootstrap_twins_kept = 0;
  std::int64_t resumed_from_frame = -1;  // first frame mapped by this run when resumed
  std::int64_t revision = 0;             // of the final map
  std::int64_t graph_edges = 0;
  std::int64_t retrieved_edges = 0;      // edges found by the vocabulary tree (loops, cuts)
  std::int64_t graph_landmarks = 0;
  // Thread 2's work per submap, in order (report.json "alignment").
  std::vector<SubmapAlignmentTiming> alignment;
  double initial_focal = 0;  // processing pixels
  int sift_max_features = 0;  // SIFT features per frame asked for (SiftOptions::max_features)
  double focal = 0;          // estimate, processing pixels
  double focal_original = 0; // estimate, original-resolution pixels
  // With a fixed (calibrated) focal: where the first submap's bundle adjustment takes it when
  // it is free, original-resolution pixels (SubmapOptions::check_fixed_focal); else unset.
  std::optional<double> free_focal_original;
  // How much lower (relative) the reprojection rms is with the focal free than fixed; set
  // with free_focal_original.
  std::optional<double> free_focal_rms_gain;
  // The focal was estimated (not fixed) but the images did not determine it, so it was held
  // at its initial value (SubmapOptions::focal_profile_step); the profile's smaller relative
  // rms increase, when it was measured.
  bool focal_held = false;
  std::optional<double> focal_profile_rms_increase;
  // Radial distortion: the estimate (BundleAdjustmentOptions::refine_k1) or the given value;
  // whether it is an estimate; SubmapOptions::k1_profile_min_rms_increase's measure (unset when
  // not checked) and whether k1 was therefore held at its initial value.
  double k1 = 0;
  bool k1_estimated = false;
  std::optional<double> k1_profile_rms_increase;
  bool k1_held = false;
  double fps = 0;            // input frame rate
  double processing_fps = 0; // frames decoded / total time
  int processing_width = 0;
  int processing_height = 0;
  bool input_ended_early = false;
  // Live streams (engine/video/stream_source.h): whether the input was one, and the frames it
  // dropped because mapping fell behind (0 for files and folders).
  bool input_is_stream = false;
  std::int64_t frames_dropped = 0;
  // Photo folders: how many photos their EXIF capture time put somewhere else than their place
  // in name order (ImageFolderSource; 0: name order, and always 0 for a video).
  std::int64_t photos_reordered_by_time = 0;
  // Georeferencing from GPS telemetry (MappingOptions::gps_track): the file used (empty when
  // none), and the fit (ok: the outputs are in metres, east-north-up around its origin).
  std::string gps_track;
  GeoreferenceResult georeference;
  // The disconnected parts' own GPS fits (when the map was georeferenced): a part with an ok
  // fit was placed in the map by it (engine/pipeline/georeference_map.h).
  std::vector<GpsPlacedPart> georeferenced_parts;
  // The end-of-run joint bundle adjustment of the whole map (engine/alignment/global_refinement.h).
  GlobalRefinementSummary global_refinement;
  // Why frames or the whole input could not be mapped, in words for the user (also logged).
  // Bad footage (textureless, static, truncated) completes with these rather than failing:
  // the run did what the input allows, and the report says what is missing and why.
  std::vector<std::string> warnings;
  MappingTimings timings;

  nlohmann::json ToJson() const;
};

// A fixed focal that the free-focal check moves by more than this fraction is reported as
// probably wrong: on nine synthetic videos the true focal moves by at most 1.1 %, a wrong one
// comes back to within 3.3 % of the truth (SubmapOptions::check_fixed_focal).
inline constexpr double kFixedFocalWarningFraction = 0.05;
// ... and only when letting it free lowers the reprojection rms by at least this fraction:
// a wrong focal measured 0.24 % (12 % long on a synthetic lawnmower) and 0.70 % (EXIF focal of
// the Brighton Beach photos, 17 % short); the true focal of blurred or heavily compressed
// clips, which the free adjustment moved 6-9 % for nothing, 0.02-0.05 % (bench/robustness.sh).
inline constexpr double kFixedFocalMinRmsGain = 0.001;

// The user-facing explanation of what could not be mapped (MappingReport::warnings).
std::vector<std::string> Diagnose(const MappingReport& report, int min_features);

}  // namespace glam
