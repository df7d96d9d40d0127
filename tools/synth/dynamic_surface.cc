#include "tools/synth/dynamic_surface.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "tools/synth/noise.h"

namespace glam::synth {

namespace {

// Fields: wavelengths chosen so that a 300-600 m flight crosses several shores and shadows.
constexpr double kWaterWavelength = 160.0;  // m
constexpr double kCloudWavelength = 240.0;  // m
// Width of the soft water edge and of the sand band, in field units (the fields change by
// ~0.015 per metre, so about 1 m and 3 m).
constexpr double kWaterEdge = 0.015;
constexpr double kSandBand = 0.045;
constexpr double kCloudEdge = 0.05;  // ~8 m of penumbra
constexpr double kWindSpeed = 7.0;   // m/s

double Smoothstep01(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// The value below which `fraction` of the field lies over the rectangle, from a grid.
template <typename Field>
double Quantile(const Field& field, double fraction, double x0, double y0, double x1, double y1) {
  constexpr int kSide = 200;
  std::vector<double> values;
  values.reserve(kSide * kSide);
  for (int j = 0; j < kSide; ++j) {
    for (int i = 0; i < kSide; ++i) {
      values.push_back(field(x0 + (x1 - x0) * (i + 0.5) / kSide, y0 + (y1 - y0) * (j + 0.5) / kSide));
    }
  }
  const auto k = static_cast<std::size_t>(std::clamp(fraction, 0.0, 1.0) * (values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

struct Ripple {
  double wavelength;  // m
  double vx, vy;      // drift (m/s)
  double amplitude;
};
// Three layers drifting in different directions (each also renews itself unless
// SynthOptions::water_renewal_s is 0; then the coarse layer dominates from high up and the
// pattern mostly slides, like foam on a current).
constexpr Ripple kRipples[3] = {{2.0, 0.60, 0.25, 0.5}, {0.9, -0.35, 0.55, 0.3}, {0.4, 0.20, -0.50, 0.2}};

}  // namespace

DynamicSurface::DynamicSurface(const SynthOptions& o, double x0, double y0, double x1, double y1)
    : renewal_s_(o.water_renewal_s),
      water_seed_(Mix64(o.seed * 7919 + 5)),
      ripple_seed_(Mix64(o.seed * 7927 + 11)),
      cloud_seed_(Mix64(o.seed * 7933 + 17)) {
  const double wind_heading = 2.0 * std::numbers::pi * Uniform01(cloud_seed_ + 1);
  wind_ = kWindSpeed * Eigen::Vector2d(std::cos(wind_heading), std::sin(wind_heading));
  if (o.water_fraction > 0) {
    has_water_ = true;
    water_threshold_ = Quantile(
        [this](double x, double y) { return Fbm(x, y, kWaterWavelength, 4, 0.5, water_seed_); },
        o.water_fraction, x0, y0, x1, y1);
  }
  if (o.cloud_shadow_fraction > 0) {
    has_clouds_ = true;
    cloud_threshold_ = Quantile(
        [this](double x, double y) { return Fbm(x, y, kCloudWavelength, 4, 0.5, cloud_seed_); },
        1.0 - o.cloud_shadow_fraction, x0, y0, x1, y1);
  }
}

DynamicSurface::Shore DynamicSurface::ShoreAt(double x, double y) const {
  if (!has_water_) return {};
  const double v = Fbm(x, y, kWaterWavelength, 4, 0.5, water_seed_);
  return {Smoothstep01((water_threshold_ + kWaterEdge - v) / (2 * kWaterEdge)),
          Smoothstep01((water_threshold_ + kSandBand - v) / kSandBand)};
}

cv::Vec3f DynamicSurface::ShoreColor() { return cv::Vec3f(0.50f, 0.62f, 0.68f); }  // BGR

cv::Vec3f DynamicSurface::ShadeWater(const Eigen::Vector3d& p, const Eigen::Vector3d& dir,
                                     double footprint, double t, const Eigen::Vector3d& sun,
                                     const cv::Vec3f& sky) const {
  double height = 0;  // ripple height pattern, about [-1, 1]
  double slope_x = 0;
  double slope_y = 0;
  double fine = 0;  // how much of the largest layer survives the footprint filter
  for (int k = 0; k < 3; ++k) {
    const Ripple& r = kRipples[k];
    // A layer finer than the pixel's footprint averages out (no aliasing, no flicker).
    const double keep = std::clamp(1.0 - footprint / (0.5 * r.wavelength), 0.0, 1.0);
    if (k == 0) fine = keep;
    if (keep <= 0) continue;
    const double u = (p.x() - r.vx * t) / r.wavelength;
    const double v = (p.y() - r.vy * t) / r.wavelength;
    const std::uint64_t s = ripple_seed_ + 31ULL * k;
    // Renewal: the layer cross-fades from one pattern to the next every renewal_s seconds
    // (layers out of step), so a ripple is recognisable for about that long.
    double w = 0;
    std::uint64_t s0 = s;
    std::uint64_t s1 = s;
    if (renewal_s_ > 0) {
      const double phase = t / renewal_s_ + 0.37 * k;
      const double cycle = std::floor(phase);
      w = Smoothstep01(phase - cycle);
      s0 = s + 1000003ULL * static_cast<std::uint64_t>(cycle);
      s1 = s0 + 1000003ULL;
    }
    auto noise = [&](double a, double b, std::uint64_t offset) {
      const double n0 = ValueNoise(a, b, s0 + offset);
      return w > 0 ? n0 + w * (ValueNoise(a, b, s1 + offset) - n0) : n0;
    };
    height += keep * r.amplitude * noise(u, v, 0);
    slope_x += keep * r.amplitude * noise(u + 17.3, v, 1);
    slope_y += keep * r.amplitude * noise(u, v + 29.1, 2);
  }
  // The sky mirrored more at grazing angles (Schlick's Fresnel term, normal up).
  const double cos_incidence = std::clamp(std::abs(dir.z()), 0.0, 1.0);
  const double reflectance = 0.02 + 0.98 * std::pow(1.0 - cos_incidence, 5.0);
  const cv::Vec3f body(0.30f, 0.26f, 0.12f);  // BGR: dark blue-green
  cv::Vec3f color = body * static_cast<float>(1 - reflectance) + sky * static_cast<float>(reflectance);
  color *= static_cast<float>(1.0 + 0.35 * height);
  // Sun glints: where a ripple's facet mirrors the sun into the camera.
  const Eigen::Vector3d normal = Eigen::Vector3d(-0.3 * slope_x, -0.3 * slope_y, 1.0).normalized();
  const Eigen::Vector3d mirrored = dir - 2.0 * dir.dot(normal) * normal;
  const double glint = fine * 1.5 * std::pow(std::max(0.0, mirrored.dot(sun)), 3000.0);
  color += cv::Vec3f(1, 1, 1) * static_cast<float>(glint);
  return color;
}

double DynamicSurface::CloudShadow(double x, double y, double t) const {
  if (!has_clouds_) return 0;
  const double v = Fbm(x - wind_.x() * t, y - wind_.y() * t, kCloudWavelength, 4, 0.5, cloud_seed_);
  return Smoothstep01((v - cloud_threshold_ + kCloudEdge) / (2 * kCloudEdge));
}

}  // namespace glam::synth
