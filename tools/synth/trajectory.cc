#include "tools/synth/trajectory.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "engine/core/logging.h"
#include "tools/synth/noise.h"

namespace glam::synth {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// A planar curve sampled densely with its cumulative arc length; positions at arc length s
// interpolate linearly between samples a few centimetres apart.
class ArcLengthPath {
 public:
  explicit ArcLengthPath(std::vector<Eigen::Vector2d> points) : points_(std::move(points)) {
    length_.resize(points_.size(), 0.0);
    for (std::size_t k = 1; k < points_.size(); ++k) {
      length_[k] = length_[k - 1] + (points_[k] - points_[k - 1]).norm();
    }
    tangents_.resize(points_.size());
    for (std::size_t k = 0; k < points_.size(); ++k) {
      const std::size_t lo = k > 0 ? k - 1 : 0;
      const std::size_t hi = std::min(k + 1, points_.size() - 1);
      const Eigen::Vector2d d = points_[hi] - points_[lo];
      tangents_[k] = d.norm() > 1e-12 ? d.normalized() : (k > 0 ? tangents_[k - 1] : Eigen::Vector2d(1, 0));
    }
  }
  double length() const { return length_.back(); }
  Eigen::Vector2d At(double s) const { return Interpolate(points_, s); }
  // Direction of travel: the samples' tangents (centred differences), interpolated.
  double Heading(double s) const {
    const Eigen::Vector2d d = Interpolate(tangents_, s);
    return std::atan2(d.y(), d.x());
  }

 private:
  Eigen::Vector2d Interpolate(const std::vector<Eigen::Vector2d>& values, double s) const {
    s = std::clamp(s, 0.0, length());
    const auto it = std::upper_bound(length_.begin(), length_.end(), s);
    const std::size_t k = std::clamp<std::size_t>(it - length_.begin(), 1, points_.size() - 1);
    const double seg = length_[k] - length_[k - 1];
    const double a = seg > 0 ? (s - length_[k - 1]) / seg : 0.0;
    return (1 - a) * values[k - 1] + a * values[k];
  }

  std::vector<Eigen::Vector2d> points_;
  std::vector<Eigen::Vector2d> tangents_;
  std::vector<double> length_;
};

std::vector<Eigen::Vector2d> SampleBSpline(const std::vector<Eigen::Vector2d>& control,
                                           int samples_per_segment) {
  // Clamp the ends by repeating the first and last control points.
  std::vector<Eigen::Vector2d> p;
  p.push_back(control.front());
  p.push_back(control.front());
  p.insert(p.end(), control.begin(), control.end());
  p.push_back(control.back());
  p.push_back(control.back());
  std::vector<Eigen::Vector2d> out;
  for (std::size_t k = 0; k + 3 < p.size(); ++k) {
    for (int n = 0; n < samples_per_segment; ++n) {
      const double u = static_cast<double>(n) / samples_per_segment;
      const double b0 = (1 - u) * (1 - u) * (1 - u) / 6;
      const double b1 = (3 * u * u * u - 6 * u * u + 4) / 6;
      const double b2 = (-3 * u * u * u + 3 * u * u + 3 * u + 1) / 6;
      const double b3 = u * u * u / 6;
      out.push_back(b0 * p[k] + b1 * p[k + 1] + b2 * p[k + 2] + b3 * p[k + 3]);
    }
  }
  out.push_back(control.back());
  return out;
}

double GroundWidth(const SynthOptions& o) {
  return 2.0 * o.altitude * (0.5 * o.width / o.EffectiveFocal());
}

ArcLengthPath LawnmowerPath(const SynthOptions& o, double needed, double angle) {
  const double spacing = 0.5 * GroundWidth(o);
  const double strip = std::clamp(needed / 4.0, 0.5 * spacing, 8.0 * spacing);
  const Eigen::Vector2d along(std::cos(angle), std::sin(angle));
  const Eigen::Vector2d across(-along.y(), along.x());
  // Control points about one strip spacing apart: the turns get a radius of roughly half
  // the spacing (gentle for a drone) and strips stay straight between them.
  const int per_strip = std::max(2, static_cast<int>(std::ceil(strip / spacing)));
  std::vector<Eigen::Vector2d> control;
  double polygon = 0;
  for (int k = 0; polygon < 1.3 * needed + 2 * spacing; ++k) {
    const bool forward = k % 2 == 0;
    for (int n = 0; n <= per_strip; ++n) {
      const double a = strip * n / per_strip;
      const double x = forward ? a : strip - a;
      control.push_back(x * along + k * spacing * across - 0.5 * strip * along);
    }
    polygon += strip + spacing;
  }
  // ~2 cm between samples so the piecewise-linear arc-length table is smooth at frame scale.
  const int samples = std::max(64, static_cast<int>(std::ceil(spacing / 0.02)));
  return ArcLengthPath(SampleBSpline(control, samples));
}

ArcLengthPath LoopPath(const SynthOptions& o, double needed, double angle, Rng& rng) {
  // r(phi) = R (1 + a2 sin(2 phi + b2) + a3 sin(3 phi + b3)): closed, convex (a2*3 + a3*8 < 1),
  // with curvature that varies along the loop. The clip flies ~15 % past the start.
  const double b2 = rng.Range(0, 2 * kPi);
  const double b3 = rng.Range(0, 2 * kPi);
  const int n = 32768;
  std::vector<Eigen::Vector2d> unit;
  for (int k = 0; k <= 2 * n; ++k) {  // two turns so the clip may run past the start
    const double phi = 2 * kPi * k / n;
    const double r = 1 + 0.15 * std::sin(2 * phi + b2) + 0.05 * std::sin(3 * phi + b3);
    unit.emplace_back(r * std::cos(phi + angle), r * std::sin(phi + angle));
  }
  double perimeter = 0;
  for (int k = 1; k <= n; ++k) perimeter += (unit[k] - unit[k - 1]).norm();
  const double radius = std::max(needed / 1.15 / perimeter, 0.3 * o.altitude);
  if (radius * perimeter > needed) {
    GLAM_LOG_WARN("synth: the loop ({:.0f} m) is longer than the clip's path ({:.0f} m); use "
                  "more --frames to return over the start",
                  radius * perimeter, needed);
  }
  const Eigen::Vector2d start = unit.front();
  for (auto& p : unit) p = radius * (p - start);
  return ArcLengthPath(std::move(unit));
}

double Wobble(double t, double amplitude, double phase1, double phase2) {
  return amplitude * (0.7 * std::sin(2 * kPi * t / 11.0 + phase1) +
                      0.3 * std::sin(2 * kPi * t / 4.3 + phase2));
}

// Terrain heights sampled every metre along the path, smoothed with a Gaussian so the
// flight altitude varies slowly (bounded vertical acceleration).
std::vector<double> SmoothedGround(const std::vector<Eigen::Vector2d>& xy, double sigma_samples,
                                   const TerrainFn& terrain) {
  std::vector<double> raw(xy.size());
  for (std::size_t k = 0; k < xy.size(); ++k) raw[k] = terrain(xy[k].x(), xy[k].y());
  const int half = static_cast<int>(std::ceil(3 * sigma_samples));
  std::vector<double> smooth(xy.size());
  for (int k = 0; k < static_cast<int>(xy.size()); ++k) {
    double sum = 0;
    double weight = 0;
    for (int m = -half; m <= half; ++m) {
      const int idx = std::clamp(k + m, 0, static_cast<int>(xy.size()) - 1);
      const double w = std::exp(-0.5 * m * m / (sigma_samples * sigma_samples));
      sum += w * raw[idx];
      weight += w;
    }
    smooth[k] = sum / weight;
  }
  return smooth;
}

}  // namespace

SO3 CameraRotation(double heading, double pitch, double roll) {
  // Nadir camera flying along +x: image right = -y (south), image down = -x, optical axis -z.
  Eigen::Matrix3d base;
  base << 0, -1, 0,  //
      -1, 0, 0,      //
      0, 0, -1;
  const Eigen::Matrix3d rz = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).matrix();
  const Eigen::Matrix3d rx = Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()).matrix();
  const Eigen::Matrix3d ry = Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitY()).matrix();
  return SO3(Eigen::Matrix3d(rz * base * rx * ry));
}

namespace {

// Distance covered x seconds into a speed-up from rest to `speed` over `ramp` seconds, speed
// speed * (1 - cos(pi x / ramp)) / 2; the whole ramp covers speed * ramp / 2.
double SpeedUpDistance(double x, double speed, double ramp) {
  return speed * (0.5 * x - ramp / (2 * kPi) * std::sin(kPi * x / ramp));
}

// The path part of ProgressAt: metres and yaw at time t of the path's own clock.
FlightProgress PathProgress(const SynthOptions& o, double t) {
  if (o.stop_every <= 0) return {o.speed * t, 0.0, o.altitude};
  const double cruise = o.stop_every / o.speed;          // seconds between stops
  const double ramp = o.StopRampSeconds();                 // slowing down, speeding up
  const double hover = o.stop_seconds - 2 * ramp;          // the yaw in place
  const double per_cycle = o.stop_every + o.speed * ramp;  // each ramp flies speed * ramp / 2
  const double yaw = o.stop_yaw_deg * kDeg;
  const double cycle = std::floor(t / (cruise + o.stop_seconds));
  const double tau = t - cycle * (cruise + o.stop_seconds);
  const double base = cycle * per_cycle;
  if (tau < cruise) return {base + o.speed * tau, cycle * yaw, o.altitude};
  const double sigma = tau - cruise;
  const double stop_at = base + o.stop_every;
  // Speed speed * (1 + cos(pi x / ramp)) / 2 while slowing down, its mirror while speeding up.
  if (sigma < ramp) {
    return {stop_at + o.speed * (0.5 * sigma + ramp / (2 * kPi) * std::sin(kPi * sigma / ramp)),
            cycle * yaw, o.altitude};
  }
  const double hovered_at = stop_at + 0.5 * o.speed * ramp;
  if (sigma < ramp + hover) {
    const double u = (sigma - ramp) / hover;
    return {hovered_at, (cycle + 0.5 * (1 - std::cos(kPi * u))) * yaw, o.altitude};
  }
  const double rho = sigma - ramp - hover;
  return {hovered_at + SpeedUpDistance(rho, o.speed, ramp), (cycle + 1) * yaw, o.altitude};
}

// Distance covered by time t of a move of `distance` at `speed` that speeds up over `ramp`
// seconds from rest and slows down over `ramp` seconds to rest.
double RampedDistance(double t, double distance, double speed, double ramp) {
  const double duration = distance / speed + ramp;
  if (t <= 0) return 0.0;
  if (t >= duration) return distance;
  if (t < ramp) return SpeedUpDistance(t, speed, ramp);
  if (t > duration - ramp) return distance - SpeedUpDistance(duration - t, speed, ramp);
  return speed * (t - 0.5 * ramp);
}

}  // namespace

FlightProgress ProgressAt(const SynthOptions& o, double t) {
  if (o.climb_from <= 0) return PathProgress(o, t);
  const double ramp = o.ClimbRampSeconds();
  const double climbed = o.ClimbSeconds();
  if (t < climbed) {
    return {0.0, 0.0, o.climb_from + RampedDistance(t, o.altitude - o.climb_from, o.climb_speed, ramp)};
  }
  // The path starts from rest, then runs on its own clock half a ramp behind (what the
  // speed-up flew less than full speed would have).
  const double tau = t - climbed;
  if (tau < ramp) return {SpeedUpDistance(tau, o.speed, ramp), 0.0, o.altitude};
  return PathProgress(o, tau - 0.5 * ramp);
}

std::vector<SE3> MakeTrajectory(const SynthOptions& o, const TerrainFn& terrain) {
  std::vector<double> times(static_cast<std::size_t>(o.frames));
  for (int f = 0; f < o.frames; ++f) times[f] = f / o.fps;
  return MakeTrajectoryAt(o, terrain, times);
}

std::vector<SE3> MakeTrajectoryAt(const SynthOptions& o, const TerrainFn& terrain,
                                  const std::vector<double>& times) {
  Rng rng(o.seed * 7919 + 17);
  const double angle = rng.Range(0, 2 * kPi);
  const double duration = (o.frames - 1) / o.fps;
  const double needed = std::max(o.speed * duration, 1.0);
  const double wobble = o.wobble_deg * kDeg;
  const double phases[6] = {rng.Range(0, 7), rng.Range(0, 7), rng.Range(0, 7),
                            rng.Range(0, 7), rng.Range(0, 7), rng.Range(0, 7)};

  // Plan positions (x, y), headings and the path sample grid (1 m) for altitude smoothing.
  const std::size_t n_times = times.size();
  std::vector<Eigen::Vector2d> xy(n_times);
  std::vector<double> heading(n_times);
  std::vector<Eigen::Vector2d> along_path;  // 1 m samples covering the flight
  if (o.trajectory == TrajectoryKind::kOrbit) {
    const double pitch = o.pitch_deg * kDeg;
    const double radius = std::max(o.altitude * std::tan(pitch), 0.3 * o.altitude);
    for (std::size_t i = 0; i < n_times; ++i) {
      const FlightProgress p = ProgressAt(o, std::max(times[i], 0.0));
      const double phi = angle + p.metres / radius;
      xy[i] = radius * Eigen::Vector2d(std::cos(phi), std::sin(phi));
      heading[i] = phi + kPi + p.extra_yaw;  // look at the centre (turned by the stops)
    }
    const int n = static_cast<int>(std::ceil(needed)) + 1;
    for (int k = 0; k <= n; ++k) {
      const double phi = angle + k / radius;
      along_path.emplace_back(radius * std::cos(phi), radius * std::sin(phi));
    }
  } else {
    const ArcLengthPath path = o.trajectory == TrajectoryKind::kLawnmower
                                   ? LawnmowerPath(o, needed, angle)
                                   : LoopPath(o, needed, angle, rng);
    for (std::size_t i = 0; i < n_times; ++i) {
      const FlightProgress p = ProgressAt(o, std::max(times[i], 0.0));
      xy[i] = path.At(p.metres);
      heading[i] = path.Heading(p.metres) + p.extra_yaw;
    }
    const int n = static_cast<int>(std::ceil(needed)) + 1;
    for (int k = 0; k <= n; ++k) along_path.push_back(path.At(k));
  }
  const double sigma = std::max(20.0, 0.5 * o.altitude);  // metres of path = samples
  const std::vector<double> ground = SmoothedGround(along_path, sigma, terrain);

  std::vector<SE3> poses;
  poses.reserve(n_times);
  for (std::size_t i = 0; i < n_times; ++i) {
    const double t = times[i];
    const FlightProgress p = ProgressAt(o, std::max(t, 0.0));
    const double s = std::clamp(p.metres, 0.0, static_cast<double>(ground.size() - 1));
    const std::size_t k = std::min(static_cast<std::size_t>(s), ground.size() - 2);
    const double a = s - k;
    const double z = (1 - a) * ground[k] + a * ground[k + 1] + p.height;
    const double psi = heading[i] + Wobble(t, wobble, phases[0], phases[1]);
    const double pitch = o.PitchDegAt(t) * kDeg + Wobble(t, wobble, phases[2], phases[3]);
    const double roll = Wobble(t, wobble, phases[4], phases[5]);
    poses.emplace_back(CameraRotation(psi, pitch, roll), Eigen::Vector3d(xy[i].x(), xy[i].y(), z));
  }
  return poses;
}

}  // namespace glam::synth
