// Options of `glam synth`, the synthetic aerial video renderer. Defaults give a useful clip on
// their own (`glam synth --out DIR`): 1280x720 at 30 fps, 60 deg horizontal field of view,
// a lawnmower survey 100 m above the ground at 10 m/s over rolling terrain with a village.
// Everything is deterministic from `seed`, so a clip is fully described by its synth.json.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace glam::synth {

enum class TrajectoryKind { kLawnmower, kLoop, kOrbit };

// "lawnmower" | "loop" | "orbit"; throws InputError for anything else.
TrajectoryKind ParseTrajectoryKind(const std::string& name);
std::string TrajectoryKindName(TrajectoryKind kind);

struct SynthOptions {
  // --- flight ---
  TrajectoryKind trajectory = TrajectoryKind::kLawnmower;
  double altitude = 100.0;   // metres above the (smoothed) terrain under the drone
  double pitch_deg = 0.0;    // camera tilt forward from nadir: 0 = straight down
  double speed = 10.0;       // m/s along the path
  double wobble_deg = 1.5;   // amplitude of slow, smooth attitude perturbations
  // Stop-and-yaw, as pilots fly: every `stop_every` metres of path the drone slows down to a
  // hover, yaws by `stop_yaw_deg` in place, and flies on along the path keeping the new
  // heading (a nadir camera then sees the ground turned; an oblique one looks elsewhere).
  // The turn is a pure rotation without parallax, which a mapper has to track through.
  double stop_every = 0.0;    // metres of path between stops; 0 = never stop
  double stop_seconds = 6.0;  // each stop: 1.5 s slowing down, the yaw, 1.5 s speeding up
  double stop_yaw_deg = 90.0; // yaw turned during each stop (added to the path heading)
  // Take-off climb, as raw flight videos begin: the clip starts `climb_from` metres above the
  // ground at the path's start, rises straight up at `climb_speed` (smooth speed ramps) to
  // `altitude`, and only then flies the path (speeding up smoothly). A nadir camera sees the
  // ground zoom out: the motion is along the optical axis, parallax grows from nothing at the
  // image centre to most at the edges, and the ground sample distance changes several-fold.
  double climb_from = 0.0;    // metres above ground at the first frame; 0 = no climb
  double climb_speed = 5.0;   // m/s upwards
  // Gimbal tilt at the start, as pilots look ahead before pointing the camera down: the camera
  // starts `tilt_from_deg` from nadir and eases to `pitch_deg` over the first `tilt_seconds`
  // of the clip (a rotation about the image's horizontal axis, while the drone climbs or flies).
  double tilt_from_deg = 0.0;
  double tilt_seconds = 0.0;  // 0 = no tilt
  double fps = 30.0;
  int frames = 600;

  // --- camera ---
  int width = 1280;
  int height = 720;
  double focal = 0.0;  // pixels; 0 = horizontal field of view of 60 degrees
  double k1 = 0.0;
  double k2 = 0.0;
  // Rolling shutter, as most drone cameras record video: rows are exposed one after the other,
  // the top row `rolling_shutter_ms` before the bottom row, while the drone moves and turns.
  // The frame's time (and its ground-truth pose) is that of the middle row, so a global-shutter
  // mapper's best single pose per frame is the ground truth. At most one frame interval.
  double rolling_shutter_ms = 0.0;  // 0 = global shutter

  // --- world ---
  std::uint64_t seed = 1;
  double relief = 12.0;            // terrain height amplitude (m), heights lie in about +-relief
  double cell_size = 0.5;          // ground-truth heightfield resolution (m)
  double building_density = 1.0;   // 0 = no buildings, 1 = default village density
  // Things that move on their own (dynamic_surface.h): the share of the ground that is open
  // water (lakes and coasts; drifting ripples, sun glints) and the share in the shadow of
  // clouds the wind pushes across at 7 m/s. 0 = none (a static world).
  double water_fraction = 0.0;
  double cloud_shadow_fraction = 0.0;
  // Seconds over which the water's ripple pattern renews itself (wind ripples: 1-2 s);
  // 0 = a pattern that only drifts, like foam on a river current (the harder case: it is a
  // second rigid scene moving under the camera).
  double water_renewal_s = 1.5;

  // --- output ---
  std::string out;          // output directory (required by the CLI)
  bool write_frames = false;  // also write frames/NNNNNN.png
  int crf = 16;               // H.264 quality (lower = better; 16 keeps texture for SIFT)
  bool force = false;         // re-render even if `out` already holds this exact clip
  // >= 0: also write video.SRT, the clip's GPS track in DJI's layout (gps_srt_writer.h), with
  // this much Gaussian noise per axis (m); < 0: no track.
  double gps_noise_m = -1;

  // The slowing down and the speeding up of a stop (s); the yaw takes the rest of it.
  double StopRampSeconds() const;
  // Speeding up and slowing down of the climb, and the climb's whole duration (s; 0 without
  // one). The path is flown from ClimbSeconds() on.
  double ClimbRampSeconds() const;
  double ClimbSeconds() const;
  // Camera tilt from nadir (deg) at time t: tilt_from_deg eased to pitch_deg over tilt_seconds.
  double PitchDegAt(double t) const;
  // Exposure time of image row `row` (0 = top) of frame `frame` (s): frame / fps for the
  // middle row, spread over rolling_shutter_ms from the top row to the bottom one.
  double RowTime(int frame, int row) const;

  // Focal length actually used (resolves focal == 0).
  double EffectiveFocal() const;

  // Throws InputError naming the field on nonsense (negative sizes, pitch > 80 deg, ...).
  void Check() const;

  nlohmann::json ToJson() const;
};

}  // namespace glam::synth
