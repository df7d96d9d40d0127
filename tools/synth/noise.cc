#include "tools/synth/noise.h"

#include <cmath>

namespace glam::synth {

std::uint64_t Mix64(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

double Uniform01(std::uint64_t key) {
  return static_cast<double>(Mix64(key) >> 11) * (1.0 / 9007199254740992.0);
}

namespace {

double Lattice(std::int64_t ix, std::int64_t iy, std::uint64_t seed) {
  const std::uint64_t key = Mix64(seed) ^ (static_cast<std::uint64_t>(ix) * 0x9e3779b97f4a7c15ULL) ^
                            (static_cast<std::uint64_t>(iy) * 0xc2b2ae3d27d4eb4fULL);
  return 2.0 * Uniform01(key) - 1.0;
}

double Quintic(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

}  // namespace

double ValueNoise(double x, double y, std::uint64_t seed) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx);
  const auto iy = static_cast<std::int64_t>(fy);
  const double sx = Quintic(x - fx);
  const double sy = Quintic(y - fy);
  const double a = Lattice(ix, iy, seed);
  const double b = Lattice(ix + 1, iy, seed);
  const double c = Lattice(ix, iy + 1, seed);
  const double d = Lattice(ix + 1, iy + 1, seed);
  return (a + (b - a) * sx) + ((c + (d - c) * sx) - (a + (b - a) * sx)) * sy;
}

double Fbm(double x, double y, double base_wavelength, int octaves, double gain,
           std::uint64_t seed) {
  double sum = 0;
  double norm = 0;
  double amplitude = 1;
  double frequency = 1.0 / base_wavelength;
  for (int o = 0; o < octaves; ++o) {
    // Rotate each octave a little so lattice axes do not line up between octaves.
    const double angle = 0.7 * o;
    const double c = std::cos(angle);
    const double s = std::sin(angle);
    const double u = (c * x - s * y) * frequency;
    const double v = (s * x + c * y) * frequency;
    sum += amplitude * ValueNoise(u, v, seed + 1000003ULL * o);
    norm += amplitude;
    amplitude *= gain;
    frequency *= 2;
  }
  return sum / norm;
}

}  // namespace glam::synth
