// Smooth drone flights for the synthetic videos. Paths are C2 curves (a cubic B-spline for
// the lawnmower, closed analytic curves for loop and orbit) flown at constant speed by
// arc-length reparameterisation, so velocity and heading never jump (optionally with
// stop-and-yaw hovers, see ProgressAt). Altitude follows the
// terrain smoothed along the path (like a drone holding height above ground), and a slow
// attitude wobble adds the small rotations a real gimbal never fully removes.
#pragma once

#include <functional>
#include <vector>

#include "engine/core/se3.h"
#include "tools/synth/synth_options.h"

namespace glam::synth {

// Ground height (terrain without buildings) at (x, y).
using TerrainFn = std::function<double(double x, double y)>;

// Camera frame: OpenCV (x right, y down, z forward). Heading psi is the direction the top of
// the image points to, measured counter-clockwise from +x (east); pitch tilts the optical
// axis from nadir (0) towards that heading.
SO3 CameraRotation(double heading, double pitch, double roll = 0.0);

// Where the flight is at time t (s): metres flown along the path, the yaw (rad) the stops
// have added so far (SynthOptions::stop_every) and the height above the ground under the
// path (SynthOptions::climb_from). Without stops or climb: speed * t, 0 and the altitude.
// Speed falls and rises smoothly (raised cosine) around each hover, the yaw eases in and
// out, and the climb speeds up and slows down the same way before the path starts with a
// smooth speed-up, so velocity and angular rate never jump.
struct FlightProgress {
  double metres = 0;
  double extra_yaw = 0;
  double height = 0;
};
FlightProgress ProgressAt(const SynthOptions& options, double t);

// world_from_cam for frames 0 .. options.frames - 1 (time = index / fps).
std::vector<SE3> MakeTrajectory(const SynthOptions& options, const TerrainFn& terrain);

// world_from_cam at arbitrary times (s) of the same flight, e.g. the exposure time of each
// image row under a rolling shutter (SynthOptions::RowTime). The path is the one
// MakeTrajectory flies; times before 0 or after the last frame hold the path's end points
// (attitude and height still follow the clock).
std::vector<SE3> MakeTrajectoryAt(const SynthOptions& options, const TerrainFn& terrain,
                                  const std::vector<double>& times);

}  // namespace glam::synth
