#include "tools/synth/world.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "tools/synth/noise.h"

namespace glam::synth {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMaxVertices = 40e6;  // 160 MB of float heights
constexpr double kMaxTexels = 40e6;    // 120 MB of RGB8 (+1/3 for mips)
constexpr int kMipLevels = 9;          // level 0 is padded to a multiple of 2^(kMipLevels-1)

struct Road {
  std::vector<Eigen::Vector2d> points;  // every 2 m
  double width = 7;
  bool paved = true;
};

cv::Vec3f Rgb(double r, double g, double b) {
  return cv::Vec3f(static_cast<float>(b / 255), static_cast<float>(g / 255), static_cast<float>(r / 255));
}

double Smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

cv::Vec3f Lerp(const cv::Vec3f& a, const cv::Vec3f& b, double t) {
  return a + static_cast<float>(t) * (b - a);
}

std::uint64_t Key(std::uint64_t a, std::int64_t b, std::int64_t c) {
  return Mix64(a ^ Mix64(static_cast<std::uint64_t>(b) * 0x9e3779b97f4a7c15ULL +
                         static_cast<std::uint64_t>(c)));
}

// Jittered-grid Voronoi: nearest and second-nearest site distances and the nearest site key.
struct Voronoi {
  std::uint64_t id = 0;
  double d1 = 1e9;
  double d2 = 1e9;
  Eigen::Vector2d site;
};

Voronoi VoronoiAt(double x, double y, double cell, std::uint64_t seed) {
  const auto cx = static_cast<std::int64_t>(std::floor(x / cell));
  const auto cy = static_cast<std::int64_t>(std::floor(y / cell));
  Voronoi v;
  for (std::int64_t j = cy - 1; j <= cy + 1; ++j) {
    for (std::int64_t i = cx - 1; i <= cx + 1; ++i) {
      const std::uint64_t k = Key(seed, i, j);
      const double sx = (i + 0.15 + 0.7 * Uniform01(k)) * cell;
      const double sy = (j + 0.15 + 0.7 * Uniform01(k + 1)) * cell;
      const double d = (x - sx) * (x - sx) + (y - sy) * (y - sy);
      if (d < v.d1) {
        v.d2 = v.d1;
        v.d1 = d;
        v.id = k;
        v.site = Eigen::Vector2d(sx, sy);
      } else if (d < v.d2) {
        v.d2 = d;
      }
    }
  }
  v.d1 = std::sqrt(v.d1);
  v.d2 = std::sqrt(v.d2);
  return v;
}

// Tree crowns: round blobs with a lit centre and dark gaps; `cell` is the tree spacing and
// `probability` the chance that a lattice cell holds a tree. Returns coverage in [0, 1] and
// the crown shade via *shade.
double Trees(double x, double y, double cell, double probability, double r_lo, double r_hi,
             std::uint64_t seed, double* shade, std::uint64_t* tree_key) {
  const auto cx = static_cast<std::int64_t>(std::floor(x / cell));
  const auto cy = static_cast<std::int64_t>(std::floor(y / cell));
  double best = 0;
  for (std::int64_t j = cy - 1; j <= cy + 1; ++j) {
    for (std::int64_t i = cx - 1; i <= cx + 1; ++i) {
      const std::uint64_t k = Key(seed, i, j);
      if (Uniform01(k + 7) >= probability) continue;
      const double sx = (i + 0.2 + 0.6 * Uniform01(k)) * cell;
      const double sy = (j + 0.2 + 0.6 * Uniform01(k + 1)) * cell;
      const double r = cell * (r_lo + (r_hi - r_lo) * Uniform01(k + 2));
      const double d2 = ((x - sx) * (x - sx) + (y - sy) * (y - sy)) / (r * r);
      if (d2 >= 1) continue;
      const double d = std::sqrt(d2);
      const double cover = 1 - Smoothstep(0.8, 1.0, d);
      if (cover > best) {
        best = cover;
        // Lit from one side, like a sphere under the sun.
        const double lx = (x - sx) / r;
        const double ly = (y - sy) / r;
        *shade = 0.75 + 0.35 * std::sqrt(std::max(0.0, 1 - d * d)) + 0.15 * (lx + ly);
        *tree_key = k;
      }
    }
  }
  return best;
}

class Texturer {
 public:
  Texturer(const SynthOptions& o) : seed_(Mix64(o.seed * 31 + 5)) {}

  cv::Vec3f Ground(double x, double y) const {
    const Voronoi field = VoronoiAt(x, y, 48.0, seed_ + 1);
    const double h1 = Uniform01(field.id + 11);
    const double h2 = Uniform01(field.id + 12);
    const double h3 = Uniform01(field.id + 13);
    const double fine = 0.06 * ValueNoise(x / 0.35, y / 0.35, seed_ + 2) +
                        0.07 * ValueNoise(x / 1.3, y / 1.3, seed_ + 3);
    const double blotch = 1.4 * Fbm(x, y, 6.0, 3, 0.55, seed_ + 4);
    cv::Vec3f c;
    bool meadow_like = false;
    if (h1 < 0.35) {  // crops with furrows and tractor tramlines
      static const cv::Vec3f kCrops[] = {Rgb(95, 125, 55), Rgb(185, 165, 100), Rgb(130, 150, 80),
                                         Rgb(150, 140, 70)};
      c = kCrops[static_cast<int>(h2 * 4)];
      const double angle = h3 * kPi;
      const double s = x * std::cos(angle) + y * std::sin(angle);
      const double period = 1.2 + 1.3 * Uniform01(field.id + 14);
      const double stripe = 0.5 + 0.5 * std::sin(2 * kPi * s / period);
      double k = 0.78 + 0.22 * stripe + 0.15 * blotch;
      const double tram = std::fmod(std::abs(s), 21.0);
      if (std::abs(tram - 5.0) < 0.25 || std::abs(tram - 7.0) < 0.25) k *= 0.72;
      c *= static_cast<float>(k);
    } else if (h1 < 0.58) {  // meadow
      c = Lerp(Rgb(85, 120, 55), Rgb(120, 140, 70), h2);
      c *= static_cast<float>(0.9 + 0.25 * blotch);
      meadow_like = true;
    } else if (h1 < 0.72) {  // ploughed soil
      c = Lerp(Rgb(115, 90, 65), Rgb(150, 120, 90), h2);
      const double angle = h3 * kPi;
      const double s = x * std::cos(angle) + y * std::sin(angle);
      const double period = 0.8 + 0.6 * Uniform01(field.id + 15);
      const double furrow = 0.5 + 0.5 * std::sin(2 * kPi * s / period);
      c *= static_cast<float>(0.76 + 0.24 * furrow + 0.18 * blotch);
    } else if (h1 < 0.87) {  // forest: dense crowns over dark undergrowth
      double shade = 1;
      std::uint64_t tree = 0;
      const double cover = Trees(x, y, 3.2, 0.92, 0.45, 0.8, seed_ + 6, &shade, &tree);
      const cv::Vec3f crown =
          Lerp(Rgb(45, 75, 35), Rgb(80, 105, 50), Uniform01(tree + 3)) * static_cast<float>(shade);
      c = Lerp(Rgb(28, 38, 22), crown, cover);
    } else {  // stubble / dry grass
      c = Lerp(Rgb(160, 150, 105), Rgb(175, 160, 120), h2);
      const double s = x * std::cos(h3 * kPi) + y * std::sin(h3 * kPi);
      c *= static_cast<float>(0.9 + 0.06 * std::sin(2 * kPi * s / 0.9) + 0.15 * blotch);
      meadow_like = true;
    }
    // Field borders: hedges or dirt tracks along the Voronoi edges.
    const double edge = 0.5 * (field.d2 - field.d1);
    if (edge < 2.0) {
      const cv::Vec3f border = Uniform01(field.id + 16) < 0.5 ? Rgb(55, 75, 38) : Rgb(140, 125, 95);
      c = Lerp(c, border * static_cast<float>(0.9 + 0.2 * blotch), 1 - Smoothstep(0.6, 2.0, edge));
    }
    // Scattered trees on open land.
    if (h1 < 0.72 || h1 >= 0.87) {
      double shade = 1;
      std::uint64_t tree = 0;
      const double cover = Trees(x, y, 12.0, meadow_like ? 0.15 : 0.04, 0.16, 0.3, seed_ + 8, &shade, &tree);
      if (cover > 0) {
        const cv::Vec3f crown = Lerp(Rgb(40, 70, 30), Rgb(85, 110, 50), Uniform01(tree + 3)) *
                                static_cast<float>(shade);
        c = Lerp(c, crown, cover);
      }
    }
    // Shrubs, stones and bare patches: small blobs that give trackable corners everywhere.
    double shade = 1;
    std::uint64_t speck = 0;
    const double cover = Trees(x, y, 2.6, 0.22, 0.15, 0.35, seed_ + 9, &shade, &speck);
    if (cover > 0) {
      const float k = static_cast<float>(Uniform01(speck + 5) < 0.6 ? 0.7 + 0.15 * Uniform01(speck + 6)
                                                                    : 1.15 + 0.15 * Uniform01(speck + 6));
      c = Lerp(c, c * k * static_cast<float>(shade), cover * (0.5 + 0.5 * Uniform01(speck + 4)));
    }
    return c * static_cast<float>(1 + fine);
  }

  // Large-scale hue/brightness multipliers shared by all ground materials (smooth, so the
  // caller evaluates it on a coarse grid and interpolates).
  cv::Vec3f Tint(double x, double y) const {
    const double b = Fbm(x, y, 200.0, 2, 0.5, seed_ + 20);
    const double g = Fbm(x, y, 260.0, 2, 0.5, seed_ + 21);
    const double bright = 1 + 0.15 * Fbm(x, y, 30.0, 3, 0.5, seed_ + 22);
    return cv::Vec3f(static_cast<float>(bright * (1 + 0.1 * b)), static_cast<float>(bright * (1 + 0.08 * g)),
                     static_cast<float>(bright));
  }

  cv::Vec3f Road(double x, double y, bool paved) const {
    const double n = 0.05 * ValueNoise(x / 0.3, y / 0.3, seed_ + 30) +
                     0.06 * ValueNoise(x / 2.0, y / 2.0, seed_ + 31);
    const cv::Vec3f base = paved ? Rgb(78, 78, 80) : Rgb(150, 132, 100);
    return base * static_cast<float>(1 + n + 0.1 * Fbm(x, y, 15.0, 2, 0.5, seed_ + 32));
  }

  cv::Vec3f Yard(double x, double y) const {
    const double n = 0.05 * ValueNoise(x / 0.4, y / 0.4, seed_ + 40) +
                     0.12 * Fbm(x, y, 6.0, 3, 0.5, seed_ + 41);
    return Rgb(150, 145, 135) * static_cast<float>(1 + n);
  }

  cv::Vec3f Roof(const Building& b, int index, double x, double y) const {
    const std::uint64_t key = Mix64(seed_ + 50 + static_cast<std::uint64_t>(index));
    double k = 1;
    if (b.gable) {
      const double along = b.ridge_along_x ? x - b.x0 : y - b.y0;
      const double across = b.ridge_along_x ? std::abs(y - 0.5 * (b.y0 + b.y1))
                                            : std::abs(x - 0.5 * (b.x0 + b.x1));
      const auto row = static_cast<std::int64_t>(std::floor(across / 0.33));
      const auto col = static_cast<std::int64_t>(std::floor((along + 0.14 * (row % 2)) / 0.28));
      k = 0.86 + 0.22 * Uniform01(Key(key, row, col));
      if (across - row * 0.33 < 0.06) k *= 0.75;  // groove between tile rows
      if (across < 0.25) k *= 0.8;                // ridge cap
      // Weathering patches and moss.
      k *= 1 + 0.12 * Fbm(x, y, 3.0, 2, 0.5, key);
    } else {
      const double edge = std::min({x - b.x0, b.x1 - x, y - b.y0, b.y1 - y});
      k = 0.92 + 0.06 * ValueNoise(x / 0.25, y / 0.25, key) + 0.1 * Fbm(x, y, 4.0, 2, 0.5, key + 1);
      if (edge < 0.4) k *= 1.18;  // parapet
      // Roof fixtures (vents, AC units) on a 4 m lattice.
      const auto ci = static_cast<std::int64_t>(std::floor(x / 4.0));
      const auto cj = static_cast<std::int64_t>(std::floor(y / 4.0));
      const std::uint64_t unit = Key(key, ci, cj);
      if (edge > 1.5 && Uniform01(unit) < 0.18) {
        const double ux = x - ci * 4.0 - 1.0 - 1.5 * Uniform01(unit + 1);
        const double uy = y - cj * 4.0 - 1.0 - 1.5 * Uniform01(unit + 2);
        if (ux > 0 && ux < 1.2 && uy > 0 && uy < 0.9) {
          k = (ux < 0.1 || uy < 0.1) ? 0.5 : 1.35;
        }
      }
    }
    return b.roof_color * static_cast<float>(k);
  }

 private:
  std::uint64_t seed_;
};

struct Bounds {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  void Add(const Eigen::Vector2d& p) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
};

Bounds VisibleBounds(const SynthOptions& o, const std::vector<SE3>& poses) {
  const Camera camera(MakeIntrinsics(o));
  std::vector<Eigen::Vector3d> rays;
  for (int a = 0; a <= 4; ++a) {
    for (int b = 0; b <= 4; ++b) {
      const Eigen::Vector2d px(-0.5 + o.width * a / 4.0, -0.5 + o.height * b / 4.0);
      rays.push_back(camera.Unproject(px).normalized());
    }
  }
  const double max_range = 8 * o.altitude;
  Bounds bounds;
  for (const SE3& pose : poses) {
    const Eigen::Vector3d c = pose.translation();
    bounds.Add(c.head<2>());
    const double z_low = TerrainHeight(c.x(), c.y(), o) - 2 * o.relief - 1;
    for (const auto& ray : rays) {
      const Eigen::Vector3d d = pose.rotation() * ray;
      double t = max_range;
      if (d.z() < -1e-3) t = std::min(t, (z_low - c.z()) / d.z());
      bounds.Add((c + t * d).head<2>());
    }
  }
  const double margin = 20;
  bounds.x0 -= margin;
  bounds.y0 -= margin;
  bounds.x1 += margin;
  bounds.y1 += margin;
  return bounds;
}

double DistanceToRoad(const Road& road, const Eigen::Vector2d& p) {
  double best = 1e300;
  for (const auto& q : road.points) best = std::min(best, (q - p).squaredNorm());
  return std::sqrt(best);
}

std::vector<Road> MakeRoads(const Bounds& b, Rng& rng) {
  std::vector<Road> roads;
  const int count = 2 + rng.Int(0, 2);
  const double diag = std::hypot(b.x1 - b.x0, b.y1 - b.y0);
  for (int r = 0; r < count; ++r) {
    Road road;
    road.paved = r < count - 1 || rng.Next() < 0.5;
    road.width = road.paved ? rng.Range(6, 8.5) : rng.Range(3, 4);
    const Eigen::Vector2d p0(rng.Range(b.x0, b.x1), rng.Range(b.y0, b.y1));
    const double angle = rng.Range(0, kPi);
    const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
    const Eigen::Vector2d perp(-dir.y(), dir.x());
    const double amplitude = rng.Range(0, 35);
    const double wavelength = rng.Range(150, 450);
    const double phase = rng.Range(0, 2 * kPi);
    for (double s = -diag; s <= diag; s += 2) {
      road.points.push_back(p0 + s * dir + amplitude * std::sin(2 * kPi * s / wavelength + phase) * perp);
    }
    roads.push_back(std::move(road));
  }
  return roads;
}

Building RandomBuilding(const Eigen::Vector2d& centre, Rng& rng) {
  Building b;
  const double kind = rng.Next();
  double w, d, h;
  if (kind < 0.08) {  // tower
    w = rng.Range(12, 20);
    d = rng.Range(12, 20);
    h = rng.Range(20, 40);
  } else if (kind < 0.22) {  // hall / warehouse
    w = rng.Range(20, 45);
    d = rng.Range(14, 28);
    h = rng.Range(6, 12);
  } else {  // house
    w = rng.Range(8, 16);
    d = rng.Range(7, 12);
    h = rng.Range(5, 9);
  }
  if (rng.Next() < 0.5) std::swap(w, d);
  b.x0 = centre.x() - 0.5 * w;
  b.x1 = centre.x() + 0.5 * w;
  b.y0 = centre.y() - 0.5 * d;
  b.y1 = centre.y() + 0.5 * d;
  b.eave_z = h;  // relative for now
  b.gable = kind >= 0.22 && rng.Next() < 0.7;
  b.ridge_along_x = w >= d;
  static const cv::Vec3f kWalls[] = {Rgb(225, 220, 205), Rgb(215, 200, 165), Rgb(235, 225, 180),
                                     Rgb(180, 180, 178), Rgb(185, 120, 95),  Rgb(200, 190, 175)};
  static const cv::Vec3f kTiles[] = {Rgb(165, 75, 50), Rgb(140, 60, 45), Rgb(90, 90, 95),
                                     Rgb(120, 80, 60), Rgb(185, 100, 65)};
  static const cv::Vec3f kFlat[] = {Rgb(170, 170, 165), Rgb(110, 110, 112), Rgb(190, 180, 160),
                                    Rgb(140, 135, 125)};
  b.wall_color = kWalls[rng.Int(0, 5)] * static_cast<float>(rng.Range(0.9, 1.05));
  b.roof_color = b.gable ? kTiles[rng.Int(0, 4)] : kFlat[rng.Int(0, 3)];
  b.roof_color *= static_cast<float>(rng.Range(0.9, 1.1));
  b.floor_height = rng.Range(2.8, 3.6);
  b.window_period = rng.Range(2.4, 4.0);
  b.window_width = b.window_period * rng.Range(0.35, 0.6);
  return b;
}

bool Overlaps(const Building& a, const Building& b, double gap) {
  return a.x0 - gap < b.x1 && b.x0 - gap < a.x1 && a.y0 - gap < b.y1 && b.y0 - gap < a.y1;
}

std::vector<Building> PlaceBuildings(const SynthOptions& o, const Bounds& bounds,
                                     const std::vector<Road>& roads, const DynamicSurface& dynamic,
                                     Rng& rng) {
  std::vector<Building> placed;
  if (o.building_density <= 0) return placed;
  const std::uint64_t seed = Mix64(o.seed * 13 + 3);
  auto settlement = [&](const Eigen::Vector2d& p) {
    return std::clamp(0.5 + 2.0 * Fbm(p.x(), p.y(), 300.0, 2, 0.5, seed), 0.0, 1.0);
  };
  auto try_place = [&](Building b) {
    if (b.x0 < bounds.x0 + 5 || b.y0 < bounds.y0 + 5 || b.x1 > bounds.x1 - 5 || b.y1 > bounds.y1 - 5) {
      return;
    }
    for (const auto& other : placed) {
      if (Overlaps(b, other, 4.0)) return;
    }
    const Eigen::Vector2d corners[5] = {{b.x0, b.y0}, {b.x1, b.y0}, {b.x0, b.y1}, {b.x1, b.y1},
                                        {0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1)}};
    for (const auto& road : roads) {
      for (const auto& c : corners) {
        if (DistanceToRoad(road, c) < 0.5 * road.width + 2.5) return;
      }
    }
    for (const auto& c : corners) {  // no houses in the water or on the beach
      if (dynamic.ShoreAt(c.x(), c.y()).sand > 0) return;
    }
    placed.push_back(b);
  };
  // Houses lining the roads, denser where the settlement field is high.
  for (const auto& road : roads) {
    for (std::size_t k = 0; k < road.points.size(); k += static_cast<std::size_t>(rng.Int(9, 17))) {
      const Eigen::Vector2d p = road.points[k];
      if (p.x() < bounds.x0 || p.x() > bounds.x1 || p.y() < bounds.y0 || p.y() > bounds.y1) continue;
      const std::size_t k2 = std::min(k + 1, road.points.size() - 1);
      const Eigen::Vector2d dir = (road.points[k2] - road.points[k2 - 1]).normalized();
      const Eigen::Vector2d perp(-dir.y(), dir.x());
      for (int side = -1; side <= 1; side += 2) {
        if (rng.Next() > o.building_density * (0.3 + 0.7 * settlement(p))) continue;
        Building b = RandomBuilding(Eigen::Vector2d::Zero(), rng);
        const double half = 0.5 * std::max(b.x1 - b.x0, b.y1 - b.y0);
        const Eigen::Vector2d c = p + side * (0.5 * road.width + 4 + half + rng.Range(0, 6)) * perp;
        b.x0 += c.x(); b.x1 += c.x(); b.y0 += c.y(); b.y1 += c.y();
        try_place(b);
      }
    }
  }
  // Farmsteads and clusters away from the roads.
  const double lot = 60;
  for (double y = std::floor(bounds.y0 / lot) * lot; y < bounds.y1; y += lot) {
    for (double x = std::floor(bounds.x0 / lot) * lot; x < bounds.x1; x += lot) {
      const Eigen::Vector2d c0(x + rng.Range(0, lot), y + rng.Range(0, lot));
      if (rng.Next() > o.building_density * (0.15 + 0.6 * settlement(c0))) continue;
      const int n = rng.Int(1, 4);
      for (int m = 0; m < n; ++m) {
        const Eigen::Vector2d c = c0 + Eigen::Vector2d(rng.Range(-20, 20), rng.Range(-20, 20));
        try_place(RandomBuilding(c, rng));
      }
    }
  }
  return placed;
}

void FillTerrain(const SynthOptions& o, Heightfield* surface) {
  cv::parallel_for_(cv::Range(0, surface->rows()), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      for (int i = 0; i < surface->cols(); ++i) {
        const double x = surface->origin().x() + i * surface->cell_size();
        const double y = surface->origin().y() + j * surface->cell_size();
        surface->at(i, j) = static_cast<float>(TerrainHeight(x, y, o));
      }
    }
  });
}

// Snaps footprints to vertices, sets base heights from the terrain and raises the roofs.
void RaiseBuildings(std::vector<Building>* buildings, Heightfield* surface, std::vector<int>* ids) {
  const double c = surface->cell_size();
  const Eigen::Vector2d origin = surface->origin();
  ids->assign(surface->heights().size(), 0);
  for (std::size_t n = 0; n < buildings->size(); ++n) {
    Building& b = (*buildings)[n];
    const int i0 = static_cast<int>(std::round((b.x0 - origin.x()) / c));
    const int i1 = static_cast<int>(std::round((b.x1 - origin.x()) / c));
    const int j0 = static_cast<int>(std::round((b.y0 - origin.y()) / c));
    const int j1 = static_cast<int>(std::round((b.y1 - origin.y()) / c));
    b.x0 = origin.x() + i0 * c;
    b.x1 = origin.x() + i1 * c;
    b.y0 = origin.y() + j0 * c;
    b.y1 = origin.y() + j1 * c;
    double base = -1e300;
    for (int j = j0 - 1; j <= j1 + 1; ++j) {
      for (int i = i0 - 1; i <= i1 + 1; ++i) base = std::max(base, static_cast<double>(surface->at(i, j)));
    }
    b.base_z = base;
    b.eave_z += base;
    const double half_span = 0.5 * (b.ridge_along_x ? b.y1 - b.y0 : b.x1 - b.x0);
    const double slope = std::tan((30.0 + 10.0 * Uniform01(n * 977 + 1)) * kPi / 180.0);
    b.ridge_z = b.gable ? b.eave_z + half_span * slope : b.eave_z;
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const double x = origin.x() + i * c;
        const double y = origin.y() + j * c;
        double z = b.eave_z;
        if (b.gable) {
          const double across = b.ridge_along_x ? std::abs(y - 0.5 * (b.y0 + b.y1))
                                                : std::abs(x - 0.5 * (b.x0 + b.x1));
          z = b.eave_z + (half_span - across) * slope;
        }
        surface->at(i, j) = static_cast<float>(z);
        (*ids)[static_cast<std::size_t>(j) * surface->cols() + i] = static_cast<int>(n) + 1;
      }
    }
  }
}

cv::Point ToTexture(const Eigen::Vector2d& p, const Eigen::Vector2d& origin, double texel) {
  constexpr int kShift = 3;
  return cv::Point(static_cast<int>(std::lround((p.x() - origin.x()) / texel * (1 << kShift))),
                   static_cast<int>(std::lround((p.y() - origin.y()) / texel * (1 << kShift))));
}

std::vector<cv::Mat> PaintAlbedo(const SynthOptions& o, const Heightfield& surface,
                                 const std::vector<Building>& buildings,
                                 const std::vector<Road>& roads, double texel) {
  const Eigen::Vector2d origin = surface.origin();
  const double extent_x = (surface.cols() - 1) * surface.cell_size();
  const double extent_y = (surface.rows() - 1) * surface.cell_size();
  const int pad = 1 << (kMipLevels - 1);
  const int tw = (static_cast<int>(std::ceil(extent_x / texel)) + 1 + pad - 1) / pad * pad;
  const int th = (static_cast<int>(std::ceil(extent_y / texel)) + 1 + pad - 1) / pad * pad;
  constexpr int kShift = 3;

  cv::Mat paved(th, tw, CV_8U, cv::Scalar(0));
  cv::Mat dirt(th, tw, CV_8U, cv::Scalar(0));
  cv::Mat marking(th, tw, CV_8U, cv::Scalar(0));
  for (const auto& road : roads) {
    std::vector<cv::Point> pts;
    for (const auto& p : road.points) pts.push_back(ToTexture(p, origin, texel));
    const int thickness = std::max(1, static_cast<int>(std::lround(road.width / texel)));
    cv::polylines(road.paved ? paved : dirt, pts, false, cv::Scalar(255), thickness, cv::LINE_AA, kShift);
    if (road.paved) {
      const int line = std::max(1, static_cast<int>(std::lround(0.15 / texel)));
      for (std::size_t k = 0; k + 2 < road.points.size(); k += 5) {  // 4 m dash, 6 m gap
        cv::line(marking, pts[k], pts[k + 2], cv::Scalar(255), line, cv::LINE_AA, kShift);
      }
    }
  }
  cv::Mat yard(th, tw, CV_8U, cv::Scalar(0));
  cv::Mat roof_id(th, tw, CV_32S, cv::Scalar(0));
  for (std::size_t n = 0; n < buildings.size(); ++n) {
    const Building& b = buildings[n];
    const double m = 2.0 + 3.0 * Uniform01(n + 101);
    cv::rectangle(yard, ToTexture({b.x0 - m, b.y0 - m}, origin, texel),
                  ToTexture({b.x1 + m, b.y1 + m}, origin, texel), cv::Scalar(255), cv::FILLED,
                  cv::LINE_AA, kShift);
    const int c0 = static_cast<int>(std::ceil((b.x0 - origin.x()) / texel));
    const int c1 = static_cast<int>(std::floor((b.x1 - origin.x()) / texel));
    const int r0 = static_cast<int>(std::ceil((b.y0 - origin.y()) / texel));
    const int r1 = static_cast<int>(std::floor((b.y1 - origin.y()) / texel));
    roof_id(cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1)) = cv::Scalar(static_cast<int>(n) + 1);
  }
  cv::GaussianBlur(yard, yard, cv::Size(0, 0), 0.5 / texel);

  const Texturer texturer(o);
  constexpr int kTintStep = 16;  // texels per tint sample
  cv::Mat tint_coarse(th / kTintStep + 2, tw / kTintStep + 2, CV_32FC3);
  for (int r = 0; r < tint_coarse.rows; ++r) {
    for (int c = 0; c < tint_coarse.cols; ++c) {
      tint_coarse.at<cv::Vec3f>(r, c) =
          texturer.Tint(origin.x() + c * kTintStep * texel, origin.y() + r * kTintStep * texel);
    }
  }
  cv::Mat albedo(th, tw, CV_8UC3);
  cv::parallel_for_(cv::Range(0, th), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      for (int c = 0; c < tw; ++c) {
        const double x = origin.x() + c * texel;
        const double y = origin.y() + r * texel;
        cv::Vec3f color;
        const int id = roof_id.at<int>(r, c);
        if (id > 0) {
          color = texturer.Roof(buildings[id - 1], id - 1, x, y);
        } else {
          const double tu = static_cast<double>(c) / kTintStep;
          const double tv = static_cast<double>(r) / kTintStep;
          const int ti = static_cast<int>(tu);
          const int tj = static_cast<int>(tv);
          const float a = static_cast<float>(tu - ti);
          const float b = static_cast<float>(tv - tj);
          const cv::Vec3f tint =
              (1 - b) * ((1 - a) * tint_coarse.at<cv::Vec3f>(tj, ti) + a * tint_coarse.at<cv::Vec3f>(tj, ti + 1)) +
              b * ((1 - a) * tint_coarse.at<cv::Vec3f>(tj + 1, ti) + a * tint_coarse.at<cv::Vec3f>(tj + 1, ti + 1));
          color = texturer.Ground(x, y).mul(tint);
          const double yard_w = yard.at<uchar>(r, c) / 255.0;
          if (yard_w > 0) color = Lerp(color, texturer.Yard(x, y), 0.85 * yard_w);
          const double dirt_w = dirt.at<uchar>(r, c) / 255.0;
          if (dirt_w > 0) color = Lerp(color, texturer.Road(x, y, false), dirt_w);
          const double paved_w = paved.at<uchar>(r, c) / 255.0;
          if (paved_w > 0) color = Lerp(color, texturer.Road(x, y, true), paved_w);
          const double mark_w = marking.at<uchar>(r, c) / 255.0;
          if (mark_w > 0) color = Lerp(color, Rgb(225, 225, 215), 0.9 * mark_w);
        }
        albedo.at<cv::Vec3b>(r, c) = cv::Vec3b(cv::saturate_cast<uchar>(color[0] * 255),
                                               cv::saturate_cast<uchar>(color[1] * 255),
                                               cv::saturate_cast<uchar>(color[2] * 255));
      }
    }
  });
  std::vector<cv::Mat> mips{albedo};
  for (int level = 1; level < kMipLevels; ++level) {
    cv::Mat next;
    cv::resize(mips.back(), next, cv::Size(mips.back().cols / 2, mips.back().rows / 2), 0, 0,
               cv::INTER_AREA);
    mips.push_back(next);
  }
  return mips;
}

}  // namespace

Intrinsics MakeIntrinsics(const SynthOptions& o) {
  Intrinsics in;
  in.model = (o.k1 != 0 || o.k2 != 0) ? "radial" : "pinhole";
  in.width = o.width;
  in.height = o.height;
  in.fx = in.fy = o.EffectiveFocal();
  in.cx = 0.5 * (o.width - 1);
  in.cy = 0.5 * (o.height - 1);
  in.k1 = o.k1;
  in.k2 = o.k2;
  return in;
}

double TerrainHeight(double x, double y, const SynthOptions& o) {
  const std::uint64_t seed = Mix64(o.seed * 101 + 7);
  return o.relief * (1.6 * Fbm(x, y, 380.0, 6, 0.5, seed) + 0.15 * Fbm(x, y, 40.0, 2, 0.5, seed + 9));
}

World World::Generate(const SynthOptions& o, const std::vector<SE3>& poses) {
  const Bounds bounds = VisibleBounds(o, poses);
  const double area = (bounds.x1 - bounds.x0) * (bounds.y1 - bounds.y0);
  if (area / (o.cell_size * o.cell_size) > kMaxVertices) {
    throw InputError(fmt::format(
        "synth: the camera sees {:.1f} km^2, too much for a {} m heightfield; use fewer frames, a "
        "lower pitch or a larger --cell-size",
        area / 1e6, o.cell_size));
  }
  World world;
  const int cols = static_cast<int>(std::ceil((bounds.x1 - bounds.x0) / o.cell_size)) + 1;
  const int rows = static_cast<int>(std::ceil((bounds.y1 - bounds.y0) / o.cell_size)) + 1;
  world.surface_ = Heightfield(Eigen::Vector2d(bounds.x0, bounds.y0), o.cell_size, cols, rows);
  FillTerrain(o, &world.surface_);
  world.dynamic_ = std::make_shared<const DynamicSurface>(o, bounds.x0, bounds.y0, bounds.x1, bounds.y1);

  Rng rng(Mix64(o.seed * 1009 + 1));
  const std::vector<Road> roads = MakeRoads(bounds, rng);
  world.buildings_ = PlaceBuildings(o, bounds, roads, *world.dynamic_, rng);
  RaiseBuildings(&world.buildings_, &world.surface_, &world.building_id_);
  world.surface_.BuildPyramid();

  world.texel_ = std::max({0.1, 0.2 * o.cell_size, std::sqrt(area / kMaxTexels)});
  world.albedo_ = PaintAlbedo(o, world.surface_, world.buildings_, roads, world.texel_);
  GLAM_LOG_INFO("synth: world {:.0f} x {:.0f} m, heightfield {} x {} at {} m, {} buildings, texture "
                "{} x {} at {:.2f} m",
                bounds.x1 - bounds.x0, bounds.y1 - bounds.y0, cols, rows, o.cell_size,
                world.buildings_.size(), world.albedo_[0].cols, world.albedo_[0].rows, world.texel_);
  return world;
}

}  // namespace glam::synth
