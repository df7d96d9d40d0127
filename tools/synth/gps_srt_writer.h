// A DJI-style GPS track for a synthetic clip (`glam synth --gps-noise`): the subtitle file a
// DJI drone writes beside its video (`video.SRT`, one entry per frame, engine/geo/gps_track.h),
// made from the true camera positions (x east, y north, z up, metres) around a made-up origin,
// with Gaussian noise per axis like a consumer GPS. With it `glam map video.mp4` georeferences
// the map, and the result can be compared with the truth directly (shifted by the first fix).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/export/tum_trajectory.h"
#include "engine/geo/geodetic.h"

namespace glam::synth {

// Where synthetic worlds are put on the globe (a meadow in the Swiss midlands).
inline constexpr Geodetic kSynthGpsOrigin{46.95, 7.45, 550.0};

// The first entry carries no noise (it is the origin of a georeferenced result, so the truth
// maps onto the result by a shift of the first true position); the others `noise_m` (1 sigma
// per axis), from a generator seeded with `seed`.
std::string DjiSrtFromTrajectory(const std::vector<TimedPose>& truth, double noise_m, std::uint64_t seed,
                                 const Geodetic& origin = kSynthGpsOrigin);

}  // namespace glam::synth
