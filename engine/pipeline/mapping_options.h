// Everything `glam map` (and a server job) can tune, gathered in one struct so the CLI, the
// REST API and tests configure a run the same way. Intrinsics are given by users for the
// ORIGINAL video resolution (that is what calibration tools and spec sheets give), while the
// engine works in processing pixels; ResolveIntrinsics does the rescaling in one place.
#pragma once

#include <cstddef>
#include <optional>

#include "engine/core/camera.h"
#include "engine/features/klt_propagator.h"
#include "engine/geo/georeference.h"
#include "engine/features/sift_extractor.h"
#include "engine/pipeline/open_submap_preview.h"
#include "engine/pipeline/rolling_shutter.h"
#include <filesystem>

#include "engine/alignment/global_refinement.h"
#include "engine/alignment/submap_aligner.h"
#include "engine/submap/submap_options.h"
#include "engine/video/frame_source.h"

namespace glam {

// SIFT features per frame for a folder of photos (glam map without --max-features, and photo
// jobs of the server). Photos are taken seconds apart: consecutive ones overlap by ~60-80 %
// instead of ~99 % for video, so far fewer of a frame's features are matched, and tracking
// needs more to start from. On the Brighton Beach sample (18 DJI photos) 2000 features
// registered 7 photos and 8000 registered 16 (docs/benchmarks.md). The cost (~4x SIFT time
// per frame) does not matter for photo sets.
inline constexpr int kPhotoFolderMaxFeatures = 8000;

struct MappingOptions {
  FrameSourceOptions source;
  SiftOptions sift;
  SubmapOptions submap;
  AlignerOptions alignment;
  // After the last submap: one bundle adjustment of the whole map (engine/alignment/
  // global_refinement.h), for maps of up to global_refinement.max_keyframes keyframes.
  GlobalRefinementOptions global_refinement;
  // The open submap shown as a provisional tile while it is built (open_submap_preview.h).
  OpenSubmapPreviewOptions preview;
  // Vocabulary tree for finding overlapping submaps; empty = the one built into glam
  // (data/vocabulary/README.md says how it was trained).
  std::filesystem::path vocabulary;
  // Full calibration at original resolution (e.g. from --intrinsics file.json).
  std::optional<Intrinsics> intrinsics;
  // Focal length in pixels at original resolution (--focal); ignored when `intrinsics` is set.
  std::optional<double> focal_px;
  // Without either: focal guess = this x the long side (about a 64 degree horizontal field of
  // view, typical of drone cameras); the submap builder's focal estimation corrects it.
  double default_focal_factor = 0.8;
  // Frames (with features) buffered between the decoder thread and the submap builder.
  std::size_t queue_capacity = 8;
  // Completed submaps waiting for thread 2; when alignment falls behind, thread 1 waits
  // rather than piling up submaps in memory.
  std::size_t alignment_queue_capacity = 4;
  // Frames whose SIFT features are extracted at the same time (one extractor per worker). SIFT
  // is the cost that bounds throughput (~270 ms per 720p frame on one core), so on 2 cores two
  // workers nearly double the frame rate; the submap builder needs ~10 %. With KLT between
  // detections, the next `feature_workers` detection frames are extracted ahead on helper
  // threads (DecoderWorker); the output is the same for any number of workers.
  int feature_workers = 2;
  // SIFT on every N-th frame, KLT optical flow in between (engine/features/klt_propagator.h).
  // 1 = SIFT on every frame, as in the paper. N > 1: a fixed schedule. 0 = automatic: one
  // detection per kAutoDetectionSeconds of input (every 6th frame at 30 fps), taking the
  // stride into account; every frame of a photo folder (whose fps is 1).
  int detection_interval = 0;
  // Automatic schedule only, opt-in (`--detect-max-seconds`): > 0 lets the interval adapt to
  // the image motion (FeatureStageOptions::max_detection_interval) between the automatic one
  // and one detection per max_detection_seconds, aiming at detection_motion_fraction of the
  // image diagonal (median keypoint displacement) between detections. Off by default: on the
  // robustness clips 1 s at 3 % saved 29 % of the detections and 6-14 % of the wall time where
  // it stretched, but cost 7.5 % in the sum of the calibrated ATEs (a take-off climb 0.034 -> 0.098 m) and moved
  // uncalibrated focal estimates both ways (docs/benchmarks.md, "Adaptive detection schedule").
  double max_detection_seconds = 0;
  double detection_motion_fraction = 0.03;
  KltOptions klt;
  // The camera's rolling shutter: keypoints are moved to where they were at the frame's middle
  // row (engine/pipeline/rolling_shutter.h). Default: the readout is estimated on the first
  // submaps (most drone cameras record video with a rolling shutter; a global-shutter video is
  // recognised as one and maps exactly as without, docs/algorithm.md); a readout given
  // (`--rolling-shutter-ms`) is used as it is, 0 = a global shutter. Photo folders and SIFT on
  // every frame have no KLT tracks to measure the motion: nothing is estimated there.
  RollingShutterOptions rolling_shutter = EstimatedRollingShutter();
  // Continue an interrupted run in the same out_dir: submaps already persisted there are
  // reloaded and decoding restarts at the first frame the next submap needs, instead of
  // mapping the whole input again (a server restart after a crash uses this).
  bool resume = false;
  // Georeferencing (engine/geo/georeference.h): GPS telemetry of the video, a DJI subtitle
  // file (.SRT). When set, it must parse (InputError before any mapping). Unset and find_gps:
  // the video's sidecar (same name, .SRT) when it exists, or the EXIF GPS positions of a photo
  // folder; a sidecar that does not parse, or a track that does not fit, only gives a warning.
  // With a fit the outputs are in metres, east-north-up around the first GPS position
  // (report.json "georeference").
  std::optional<std::filesystem::path> gps_track;
  bool find_gps = true;
  GeoreferenceOptions georeference;

  void Check() const;  // throws InputError

  // detection_interval resolved for an input of `fps` frames per second (before stride), and
  // the longest interval the automatic schedule may stretch it to (= the interval when fixed).
  int EffectiveDetectionInterval(double fps) const;
  int EffectiveMaxDetectionInterval(double fps) const;
};

// Time between SIFT detections under detection_interval = 0: at 30 fps KLT then bridges 5
// frames (~0.17 s), short enough for the ground to shift by a fraction of the image only.
inline constexpr double kAutoDetectionSeconds = 0.2;

// Switches `options` to the paper's method wherever this implementation deviates from it by
// default and an option exists (docs/algorithm.md gives each deviation and its measured
// reason): SIFT on every frame, strongest features over the whole frame (no grid), the
// paper's keyframe and bootstrap rules alone (no parallax rules), one focal per keyframe under
// the constant weak prior (no shared focal, no prior growth, no submap rebuild when the focal
// moves), completion by PnP relocalisation only (no completion bundle adjustment), no
// extension of a short final submap; thread 2 with landmark-only edges (no shared frames) and
// whole-graph solves (no local window); no global refinement at the end. Kept, because they
// have no paper counterpart to go back to or the paper leaves them open: RootSIFT (the built-in vocabulary is trained on it),
// the inlier thresholds' scaling with the feature count, the outlier filters' parameters, the
// verifier's checks. For comparing against the paper (`glam map --paper`); slower (SIFT on every
// frame: ~5 fps at 1280x720) and on the synthetic test clips it maps less of the ground.
void UsePaperMethod(MappingOptions* options);

// A calibration is given (`glam map --intrinsics`, job option `intrinsics`): it is trusted, so
// its focal and distortion stay fixed (on flat nadir footage the focal trades off against
// altitude and k1 against the ground's curvature, so refining a real calibration costs
// accuracy; `glam map --refine-focal` turns the focal's refinement back on).
void UseCalibration(MappingOptions* options, const Intrinsics& intrinsics);

// Intrinsics at processing size for `info`: the given calibration or focal rescaled by
// info.scale (pixel centres at integer coordinates: c' = (c + 0.5) s - 0.5), or the default
// guess with the principal point at the image centre. Throws InputError if a given
// calibration's width/height do not match the input's original size.
Intrinsics ResolveIntrinsics(const MappingOptions& options, const FrameSourceInfo& info);

}  // namespace glam
