#include "tools/synth/synth_options.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam::synth {

TrajectoryKind ParseTrajectoryKind(const std::string& name) {
  if (name == "lawnmower") return TrajectoryKind::kLawnmower;
  if (name == "loop") return TrajectoryKind::kLoop;
  if (name == "orbit") return TrajectoryKind::kOrbit;
  throw InputError("unknown trajectory '" + name + "' (expected lawnmower, loop or orbit)");
}

std::string TrajectoryKindName(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kLawnmower: return "lawnmower";
    case TrajectoryKind::kLoop: return "loop";
    case TrajectoryKind::kOrbit: return "orbit";
  }
  return "?";
}

double SynthOptions::EffectiveFocal() const {
  if (focal > 0) return focal;
  const double half_fov = 30.0 * std::numbers::pi / 180.0;
  return 0.5 * width / std::tan(half_fov);
}

double SynthOptions::StopRampSeconds() const { return std::min(1.5, 0.25 * stop_seconds); }

double SynthOptions::ClimbRampSeconds() const {
  if (climb_from <= 0) return 0.0;
  return std::min(1.5, 0.5 * (altitude - climb_from) / climb_speed);
}

double SynthOptions::ClimbSeconds() const {
  if (climb_from <= 0) return 0.0;
  // Each ramp covers half the distance it would at full speed.
  return (altitude - climb_from) / climb_speed + ClimbRampSeconds();
}

double SynthOptions::PitchDegAt(double t) const {
  if (tilt_seconds <= 0 || t >= tilt_seconds) return pitch_deg;
  const double u = std::max(0.0, t) / tilt_seconds;
  return pitch_deg + (tilt_from_deg - pitch_deg) * 0.5 * (1 + std::cos(std::numbers::pi * u));
}

double SynthOptions::RowTime(int frame, int row) const {
  const double t = frame / fps;
  if (rolling_shutter_ms <= 0 || height < 2) return t;
  const double from_middle = static_cast<double>(row) / (height - 1) - 0.5;
  return t + 1e-3 * rolling_shutter_ms * from_middle;
}

void SynthOptions::Check() const {
  CheckInRange("synth.altitude", altitude, 20.0, 1000.0);
  CheckInRange("synth.pitch_deg", pitch_deg, 0.0, 80.0);
  CheckInRange("synth.speed", speed, 0.5, 60.0);
  CheckInRange("synth.wobble_deg", wobble_deg, 0.0, 10.0);
  CheckGreaterEqual("synth.stop_every", stop_every, 0.0);
  if (stop_every > 0) {
    CheckInRange("synth.stop_every", stop_every, 1.0, 1e6);
    CheckInRange("synth.stop_seconds", stop_seconds, 1.0, 600.0);
    CheckInRange("synth.stop_yaw_deg", stop_yaw_deg, -360.0, 360.0);
  }
  CheckGreaterEqual("synth.climb_from", climb_from, 0.0);
  if (climb_from > 0) {
    // Below ~10 m the roofs of the village come too close to the camera.
    CheckInRange("synth.climb_from", climb_from, 10.0, altitude - 1.0);
    CheckInRange("synth.climb_speed", climb_speed, 0.5, 20.0);
  }
  CheckInRange("synth.tilt_seconds", tilt_seconds, 0.0, 600.0);
  if (tilt_seconds > 0) CheckInRange("synth.tilt_from_deg", tilt_from_deg, 0.0, 80.0);
  CheckInRange("synth.fps", fps, 1.0, 240.0);
  CheckInRange("synth.frames", frames, 1, 1000000);
  CheckInRange("synth.width", width, 16, 7680);
  CheckInRange("synth.height", height, 16, 4320);
  if (width % 2 != 0 || height % 2 != 0) {
    throw InputError("synth.width and synth.height must be even (H.264 yuv420p)");
  }
  CheckGreaterEqual("synth.focal", focal, 0.0);
  if (focal > 0) CheckInRange("synth.focal", focal, 0.1 * width, 20.0 * width);
  CheckInRange("synth.k1", k1, -0.5, 0.5);
  CheckInRange("synth.k2", k2, -0.5, 0.5);
  // A sensor cannot take longer to read out one frame than the frame interval.
  CheckInRange("synth.rolling_shutter_ms", rolling_shutter_ms, 0.0, 1000.0 / fps);
  CheckInRange("synth.relief", relief, 0.0, 200.0);
  CheckInRange("synth.cell_size", cell_size, 0.1, 2.0);
  CheckInRange("synth.building_density", building_density, 0.0, 3.0);
  CheckInRange("synth.water_fraction", water_fraction, 0.0, 0.95);
  CheckInRange("synth.cloud_shadow_fraction", cloud_shadow_fraction, 0.0, 0.9);
  CheckInRange("synth.water_renewal_s", water_renewal_s, 0.0, 600.0);
  CheckInRange("synth.crf", crf, 0, 51);
  if (gps_noise_m > 100) throw InputError("synth.gps_noise_m must be at most 100 m (negative: no GPS track)");
  // Distortion must stay invertible (monotonic radius) over the image corners, otherwise
  // Camera::Unproject is ill-defined there and the render would fold over itself.
  const double f = EffectiveFocal();
  const double r_max = std::hypot(0.5 * width, 0.5 * height) / f;
  for (int i = 1; i <= 100; ++i) {
    const double r = r_max * i / 100.0;
    const double derivative = 1 + 3 * k1 * r * r + 5 * k2 * r * r * r * r;
    if (derivative <= 0.05) {
      throw InputError("synth.k1/k2: distortion is not invertible inside the image");
    }
  }
}

nlohmann::json SynthOptions::ToJson() const {
  nlohmann::json j{{"trajectory", TrajectoryKindName(trajectory)},
                        {"altitude", altitude},
                        {"pitch_deg", pitch_deg},
                        {"speed", speed},
                        {"wobble_deg", wobble_deg},
                        {"fps", fps},
                        {"frames", frames},
                        {"width", width},
                        {"height", height},
                        {"focal", EffectiveFocal()},
                        {"k1", k1},
                        {"k2", k2},
                        {"seed", seed},
                        {"relief", relief},
                        {"cell_size", cell_size},
                        {"building_density", building_density},
                        {"crf", crf},
                        {"generator", "glam synth 1"}};
  // Only when used, so that clips rendered before the option existed stay up to date.
  if (gps_noise_m >= 0) j["gps_noise_m"] = gps_noise_m;
  if (stop_every > 0) {
    j["stop_every"] = stop_every;
    j["stop_seconds"] = stop_seconds;
    j["stop_yaw_deg"] = stop_yaw_deg;
  }
  if (climb_from > 0) {
    j["climb_from"] = climb_from;
    j["climb_speed"] = climb_speed;
  }
  if (tilt_seconds > 0) {
    j["tilt_from_deg"] = tilt_from_deg;
    j["tilt_seconds"] = tilt_seconds;
  }
  if (rolling_shutter_ms > 0) j["rolling_shutter_ms"] = rolling_shutter_ms;
  if (water_fraction > 0) {
    j["water_fraction"] = water_fraction;
    j["water_renewal_s"] = water_renewal_s;
  }
  if (cloud_shadow_fraction > 0) j["cloud_shadow_fraction"] = cloud_shadow_fraction;
  return j;
}

}  // namespace glam::synth
