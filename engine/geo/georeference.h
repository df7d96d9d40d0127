// Puts a map in metres, east-north-up, from GPS positions of its cameras. A monocular map has
// no scale and no heading of its own; the GPS track that drones record beside the video has
// both, with metre-level noise per sample that hundreds of samples average out. The fit is a
// similarity enu_from_world between the map's camera centres and the GPS positions at the same
// video times, robust to GPS outliers (multipath, the first fixes), in one of two forms:
//  * full (7 degrees of freedom, Umeyama) when the flight spreads over both horizontal
//    directions, so that a tilt of the map frame is observable;
//  * yaw, scale and offset only (4 degrees of freedom) for a flight along a line, where the
//    roll about the line is not: the map's levelled world frame (z up) is kept vertical.
// GPS altitude is noisier than its horizontal position; the full fit weighs it the same
// (consumer GPS: ~2-5 m vertical), which the 4-DoF form avoids.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/core/sim3.h"
#include "engine/geo/geodetic.h"
#include "engine/geo/gps_track.h"

namespace glam {

struct GeoreferenceOptions {
  // Fewer GPS samples matched to posed frames than this: no georeference.
  int min_samples = 10;
  // The matched GPS positions must span at least this (metres, horizontally, along their main
  // direction, from their spread: sqrt(12) x the standard deviation, so the noise of a hover
  // does not count): over a shorter path GPS noise would set the scale and heading.
  double min_extent_m = 10.0;
  // ... and the fit's rms may be at most this fraction of that span (consumer GPS scatters
  // 2-5 m: a flight of a few metres is refused rather than scaled by noise).
  double max_rms_fraction = 0.25;
  // Samples farther than max(outlier_factor x the median residual, min_outlier_m) from the
  // fit are dropped and the fit repeated (twice).
  double outlier_factor = 3.0;
  double min_outlier_m = 2.0;
  // The full fit needs the second horizontal spread (singular value of the centred GPS
  // positions) to be at least this fraction of the first, and to span min_extent_m too.
  double min_spread_ratio = 0.2;

  void Check() const;  // throws InputError
};

struct GeoreferenceResult {
  bool ok = false;
  std::string reason;  // why not, when !ok
  Sim3 enu_from_world;
  Geodetic origin;  // of the ENU frame: the first GPS sample with a fix
  bool full = false;  // 7-DoF fit (else yaw, scale and offset)
  int samples_matched = 0;
  int samples_used = 0;  // after outlier removal
  double rms_m = 0;      // of the used samples
  double extent_m = 0;
};

// `centres_by_frame`: world camera centres by frame index, frames at t = index / fps (as
// trajectory.tum). GPS samples are matched to the frame nearest their time (within half a
// frame).
GeoreferenceResult FitGeoreference(const std::map<std::int64_t, Eigen::Vector3d>& centres_by_frame, double fps,
                                   const std::vector<GpsSample>& gps, const GeoreferenceOptions& options = {});

}  // namespace glam
