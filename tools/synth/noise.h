// Deterministic procedural noise for the synthetic world. Value noise on an integer lattice
// hashed from (ix, iy, seed) is defined on the whole plane, so the terrain can be queried
// before the world's extent is known (the flight path follows the terrain, and the extent
// follows the flight path). Integer hashing keeps results identical across compilers and
// standard libraries (std::*_distribution is not portable).
#pragma once

#include <cstdint>

namespace glam::synth {

// 64-bit mix (splitmix64 finaliser).
std::uint64_t Mix64(std::uint64_t x);

// Uniform in [0, 1) from a key.
double Uniform01(std::uint64_t key);

// Small deterministic generator: Next() in [0, 1), stream defined by the seed.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(Mix64(seed ^ 0x9e3779b97f4a7c15ULL)) {}
  double Next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return static_cast<double>(Mix64(state_) >> 11) * (1.0 / 9007199254740992.0);
  }
  double Range(double lo, double hi) { return lo + (hi - lo) * Next(); }
  int Int(int lo, int hi_inclusive) {
    return lo + static_cast<int>(Next() * (hi_inclusive - lo + 1));
  }

 private:
  std::uint64_t state_;
};

// Smooth (C2, quintic-interpolated) value noise in [-1, 1] with unit lattice spacing.
double ValueNoise(double x, double y, std::uint64_t seed);

// Fractal sum of `octaves` ValueNoise layers: wavelength halves and amplitude scales by
// `gain` per octave. Normalised so the result stays in about [-1, 1].
double Fbm(double x, double y, double base_wavelength, int octaves, double gain,
           std::uint64_t seed);

}  // namespace glam::synth
