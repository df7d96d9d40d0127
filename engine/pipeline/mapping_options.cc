#include "engine/pipeline/mapping_options.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {

void MappingOptions::Check() const {
  source.Check();
  sift.Check();
  submap.Check();
  alignment.Check();
  global_refinement.Check();
  preview.Check();
  if (intrinsics) intrinsics->Check();
  if (focal_px) CheckGreater("MappingOptions.focal_px", *focal_px, 0.0);
  CheckInRange("MappingOptions.default_focal_factor", default_focal_factor, 0.05, 20.0);
  CheckGreater("MappingOptions.queue_capacity", queue_capacity, std::size_t{0});
  CheckGreater("MappingOptions.alignment_queue_capacity", alignment_queue_capacity, std::size_t{0});
  CheckInRange("MappingOptions.feature_workers", feature_workers, 1, 16);
  CheckInRange("MappingOptions.detection_interval", detection_interval, 0, 1000);
  CheckInRange("MappingOptions.max_detection_seconds", max_detection_seconds, 0.0, 10.0);
  CheckInRange("MappingOptions.detection_motion_fraction", detection_motion_fraction, 0.001, 1.0);
  klt.Check();
  rolling_shutter.Check();
  georeference.Check();
}

namespace {

// Frames of the input (after stride) in `seconds`, at least one.
int FramesIn(double seconds, double fps, int stride) {
  const double frames_per_second = fps > 0 ? fps / stride : 1.0;
  return std::max(1, static_cast<int>(std::lround(frames_per_second * seconds)));
}

}  // namespace

int MappingOptions::EffectiveDetectionInterval(double fps) const {
  if (detection_interval > 0) return detection_interval;
  return FramesIn(kAutoDetectionSeconds, fps, source.stride);
}

int MappingOptions::EffectiveMaxDetectionInterval(double fps) const {
  const int shortest = EffectiveDetectionInterval(fps);
  if (detection_interval > 0 || shortest == 1) return shortest;
  return std::max(shortest, FramesIn(max_detection_seconds, fps, source.stride));
}

void UsePaperMethod(MappingOptions* options) {
  options->detection_interval = 1;
  options->sift.grid_cols = 0;
  options->sift.grid_rows = 0;
  SubmapOptions& submap = options->submap;
  submap.max_keyframe_parallax_deg = 0;
  submap.min_map_coverage = 0;
  submap.bootstrap_accept_parallax_deg = 0;
  submap.bundle_adjustment.share_focal = false;
  submap.focal_prior_growth = 0;
  submap.rebuild_focal_change = 0;
  submap.completion_ba_max_frames = 0;
  submap.centre_smoothing.half_window_s = 0;
  submap.extend_short_final_submap = false;
  submap.isolated_filter_once = false;
  submap.bootstrap_rotation_veto_fraction = 0;
  submap.bootstrap_twin_focal_step = 0;
  submap.hover_max_speed = 0;
  submap.moving_landmark_frames = 0;
  submap.focal_profile_step = 0;
  submap.bundle_adjustment.refine_k1 = false;
  submap.epipolar_triangulation_matching = false;
  submap.duplicate_check_in_view = false;
  submap.local_ba_keyframes = 0;
  options->alignment.use_shared_frames = false;
  options->alignment.local_window = 0;
  options->alignment.max_demotable_submaps = 0;
  options->global_refinement.max_keyframes = 0;
  options->rolling_shutter = RollingShutterOptions{};  // a global shutter
}

void UseCalibration(MappingOptions* options, const Intrinsics& intrinsics) {
  options->intrinsics = intrinsics;
  options->submap.bundle_adjustment.refine_focal = false;
  options->submap.bundle_adjustment.refine_k1 = false;
  // Epipolar lines are only as good as the camera model they are drawn with.
  options->submap.epipolar_triangulation_matching = true;
}

Intrinsics ResolveIntrinsics(const MappingOptions& options, const FrameSourceInfo& info) {
  const double s = info.scale;
  Intrinsics out;
  out.width = info.processing_size.width;
  out.height = info.processing_size.height;
  if (options.intrinsics) {
    const Intrinsics& in = *options.intrinsics;
    if (in.width != info.original_size.width || in.height != info.original_size.height) {
      throw InputError(fmt::format(
          "intrinsics are for {}x{} images but the input is {}x{}; give them at the video's "
          "original resolution",
          in.width, in.height, info.original_size.width, info.original_size.height));
    }
    out.model = in.model;
    out.fx = in.fx * s;
    out.fy = in.fy * s;
    out.cx = (in.cx + 0.5) * s - 0.5;
    out.cy = (in.cy + 0.5) * s - 0.5;
    out.k1 = in.k1;  // radial coefficients act on normalised coordinates: scale-free
    out.k2 = in.k2;
  } else {
    const double focal = options.focal_px
                             ? *options.focal_px * s
                             : options.default_focal_factor *
                                   std::max(out.width, out.height);
    out.fx = out.fy = focal;
    out.cx = (out.width - 1) / 2.0;
    out.cy = (out.height - 1) / 2.0;
  }
  out.Check();
  return out;
}

}  // namespace glam
