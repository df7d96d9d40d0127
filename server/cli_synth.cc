// `glam synth`: render a synthetic aerial video with exact ground truth (tools/synth).
#include <string>

#include "server/commands.h"
#include "tools/synth/synth.h"

namespace glam::cli {

void RegisterSynthCommand(CLI::App& app) {
  auto options = std::make_shared<synth::SynthOptions>();
  auto trajectory = std::make_shared<std::string>("lawnmower");
  CLI::App* cmd = app.add_subcommand(
      "synth", "Render a synthetic aerial video with ground truth (trajectory, surface, intrinsics)");
  cmd->add_option("--out", options->out, "Output directory")->required();
  cmd->add_option("--trajectory", *trajectory, "lawnmower | loop | orbit")->capture_default_str();
  cmd->add_option("--altitude", options->altitude, "Flight height above ground (m)")->capture_default_str();
  cmd->add_option("--pitch-deg", options->pitch_deg, "Camera tilt from nadir (deg), 0..80")->capture_default_str();
  cmd->add_option("--speed", options->speed, "Ground speed (m/s)")->capture_default_str();
  cmd->add_option("--wobble-deg", options->wobble_deg, "Attitude wobble amplitude (deg)")->capture_default_str();
  cmd->add_option("--stop-every", options->stop_every,
                  "Stop-and-yaw: hover every this many metres of path, yaw, fly on; 0 = never")
      ->capture_default_str();
  cmd->add_option("--stop-seconds", options->stop_seconds,
                  "Duration of each stop (s): slowing down, the yaw, speeding up")
      ->capture_default_str();
  cmd->add_option("--stop-yaw-deg", options->stop_yaw_deg, "Yaw turned in place at each stop (deg)")
      ->capture_default_str();
  cmd->add_option("--climb-from", options->climb_from,
                  "Take-off climb: start this high above ground (m), rise to --altitude, then fly; 0 = no climb")
      ->capture_default_str();
  cmd->add_option("--climb-speed", options->climb_speed, "Vertical speed of the climb (m/s)")
      ->capture_default_str();
  cmd->add_option("--tilt-from-deg", options->tilt_from_deg,
                  "Gimbal tilt at the start: the camera starts this far from nadir (deg) and eases to --pitch-deg")
      ->capture_default_str();
  cmd->add_option("--tilt-seconds", options->tilt_seconds, "Duration of that tilt (s); 0 = no tilt")
      ->capture_default_str();
  cmd->add_option("--fps", options->fps, "Frame rate")->capture_default_str();
  cmd->add_option("--frames", options->frames, "Number of frames")->capture_default_str();
  cmd->add_option("--width", options->width, "Image width (px, even)")->capture_default_str();
  cmd->add_option("--height", options->height, "Image height (px, even)")->capture_default_str();
  cmd->add_option("--focal", options->focal, "Focal length (px); 0 = 60 deg horizontal FOV")->capture_default_str();
  cmd->add_option("--k1", options->k1, "Radial distortion k1")->capture_default_str();
  cmd->add_option("--k2", options->k2, "Radial distortion k2")->capture_default_str();
  cmd->add_option("--rolling-shutter-ms", options->rolling_shutter_ms,
                  "Rolling shutter: readout time from the top row to the bottom row (ms), at most one "
                  "frame interval; 0 = global shutter. Ground truth is the middle row's pose")
      ->capture_default_str();
  cmd->add_option("--seed", options->seed, "World and flight seed")->capture_default_str();
  cmd->add_option("--relief", options->relief, "Terrain relief amplitude (m)")->capture_default_str();
  cmd->add_option("--cell-size", options->cell_size, "Ground-truth heightfield cell (m)")->capture_default_str();
  cmd->add_option("--building-density", options->building_density, "0 = none, 1 = village")->capture_default_str();
  cmd->add_option("--water", options->water_fraction,
                  "Share of the ground that is open water (0..0.95): lakes and coasts whose ripples drift "
                  "and glint in the sun, i.e. image content that moves on its own")
      ->capture_default_str();
  cmd->add_option("--water-renewal", options->water_renewal_s,
                  "Seconds over which the water's ripples renew themselves (wind ripples); 0 = they only "
                  "drift, like foam on a river current")
      ->capture_default_str();
  cmd->add_option("--cloud-shadows", options->cloud_shadow_fraction,
                  "Share of the ground in the shadow of clouds (0..0.9) that the wind pushes across at 7 m/s")
      ->capture_default_str();
  cmd->add_option("--crf", options->crf, "H.264 CRF (quality, lower is better)")->capture_default_str();
  cmd->add_option("--gps-noise", options->gps_noise_m,
                  "Also write video.SRT, the flight's GPS track in DJI's subtitle layout (glam map then "
                  "georeferences the map), with this much Gaussian noise per axis in metres");
  cmd->add_flag("--frames-dir", options->write_frames, "Also write frames/NNNNNN.png");
  cmd->add_flag("--force", options->force, "Re-render even if the output is up to date");
  cmd->callback([options, trajectory] {
    options->trajectory = synth::ParseTrajectoryKind(*trajectory);
    synth::RunSynth(*options);
  });
}

}  // namespace glam::cli
