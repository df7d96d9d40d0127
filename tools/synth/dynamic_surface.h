// What changes over time in the synthetic world: open water whose ripples drift and glint, and
// cloud shadows that the wind pushes across the ground. Everything else in the world is
// static (Lambertian under a fixed sun), which no real flight is: over a coast, a river or a
// lake a large part of the image moves on its own, and on a cloudy day shadow edges sweep
// across fields. A mapper must take neither for the ground's motion; these options let a clip
// test that against ground truth.
//
// Geometry is not touched: water is an appearance of the terrain (the ground-truth surface
// stays the heightfield, so points triangulated on moving ripples count as map errors), and
// a cloud shadow only dims the sun's share of the light. Both are pure functions of the seed,
// the position and the time, so renders stay deterministic.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tools/synth/synth_options.h"

namespace glam::synth {

class DynamicSurface {
 public:
  // Chooses the water and cloud thresholds so that about `water_fraction` of the ground in
  // [x0, x1] x [y0, y1] (the area the flight sees) is water and `cloud_shadow_fraction` of it
  // lies in shadow at time 0 (quantiles of the fields over that area; the share of the
  // pixels is reported in synth.json, as views are not spread evenly over the area).
  DynamicSurface(const SynthOptions& options, double x0, double y0, double x1, double y1);

  bool has_water() const { return has_water_; }
  bool has_clouds() const { return has_clouds_; }
  // Cloud drift (m/s, world x and y).
  const Eigen::Vector2d& wind() const { return wind_; }

  // The coast at ground point (x, y), both from one evaluation of the water field:
  // `water` is 1 on open water, 0 on land and in between at the ~1 m soft waterline; `sand`
  // is 1 at the waterline fading to 0 ~3 m inland (the band the renderer paints as sand).
  struct Shore {
    double water = 0;
    double sand = 0;
  };
  Shore ShoreAt(double x, double y) const;

  // Colour of the water surface at `point` seen along unit ray `dir` at time `t` (s):
  // a dark body, the sky reflected more at grazing angles, drifting ripples (filtered by the
  // pixel footprint so they do not alias) and sun glints where a ripple mirrors the sun.
  // The ripples drift at 0.3-0.65 m/s and, unless SynthOptions::water_renewal_s is 0, renew
  // themselves over that many seconds (wind ripples come and go; foam on a river current
  // only drifts).
  cv::Vec3f ShadeWater(const Eigen::Vector3d& point, const Eigen::Vector3d& dir, double footprint,
                       double t, const Eigen::Vector3d& sun, const cv::Vec3f& sky) const;

  // Sand colour of the shore band.
  static cv::Vec3f ShoreColor();

  // Share of the direct sunlight a cloud blocks at ground point (x, y) at time t: 0 in the
  // sun, up to 1 in the core of a shadow, with soft edges a few metres wide.
  double CloudShadow(double x, double y, double t) const;

 private:
  double renewal_s_ = 0;
  bool has_water_ = false;
  bool has_clouds_ = false;
  double water_threshold_ = 0;
  double cloud_threshold_ = 0;
  std::uint64_t water_seed_ = 0;
  std::uint64_t ripple_seed_ = 0;
  std::uint64_t cloud_seed_ = 0;
  Eigen::Vector2d wind_;  // cloud drift (m/s)
};

}  // namespace glam::synth
