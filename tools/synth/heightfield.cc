#include "tools/synth/heightfield.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>

#include <nlohmann/json.hpp>

#include "engine/core/error.h"

namespace glam::synth {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNudge = 1e-7;  // metres: moves a block lookup just past a boundary
}  // namespace

Heightfield::Heightfield(const Eigen::Vector2d& origin, double cell_size, int cols, int rows)
    : origin_(origin),
      cell_(cell_size),
      cols_(cols),
      rows_(rows),
      heights_(static_cast<std::size_t>(cols) * rows, 0.0f) {
  GLAM_CHECK(cols >= 2 && rows >= 2 && cell_size > 0, "bad heightfield size");
}

double Heightfield::HeightAt(double x, double y) const {
  const double u = std::clamp((x - origin_.x()) / cell_, 0.0, cols_ - 1.000001);
  const double v = std::clamp((y - origin_.y()) / cell_, 0.0, rows_ - 1.000001);
  const int i = static_cast<int>(u);
  const int j = static_cast<int>(v);
  const double a = u - i;
  const double b = v - j;
  const double h00 = at(i, j);
  const double h10 = at(i + 1, j);
  const double h01 = at(i, j + 1);
  const double h11 = at(i + 1, j + 1);
  if (a >= b) return h00 + (h10 - h00) * a + (h11 - h10) * b;
  return h00 + (h11 - h01) * a + (h01 - h00) * b;
}

void Heightfield::BuildPyramid() {
  levels_.clear();
  Level base;
  base.cols = cols_ - 1;
  base.rows = rows_ - 1;
  base.max.resize(static_cast<std::size_t>(base.cols) * base.rows);
  for (int j = 0; j < base.rows; ++j) {
    for (int i = 0; i < base.cols; ++i) {
      base.max[static_cast<std::size_t>(j) * base.cols + i] =
          std::max({at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)});
    }
  }
  levels_.push_back(std::move(base));
  while (levels_.back().cols > 1 || levels_.back().rows > 1) {
    const Level& below = levels_.back();
    Level up;
    up.cols = (below.cols + 1) / 2;
    up.rows = (below.rows + 1) / 2;
    up.max.assign(static_cast<std::size_t>(up.cols) * up.rows, -std::numeric_limits<float>::max());
    for (int j = 0; j < below.rows; ++j) {
      for (int i = 0; i < below.cols; ++i) {
        float& m = up.max[static_cast<std::size_t>(j / 2) * up.cols + i / 2];
        m = std::max(m, below.max[static_cast<std::size_t>(j) * below.cols + i]);
      }
    }
    levels_.push_back(std::move(up));
  }
  const auto [lo, hi] = std::minmax_element(heights_.begin(), heights_.end());
  min_height_ = *lo;
  max_height_ = *hi;
}

bool Heightfield::IntersectCell(int i, int j, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                double t_in, double t_out, RayHit* hit) const {
  const double h00 = at(i, j);
  const double h10 = at(i + 1, j);
  const double h01 = at(i, j + 1);
  const double h11 = at(i + 1, j + 1);
  const double a0 = o.x() - i;
  const double b0 = o.y() - j;
  // Split [t_in, t_out] where the ray crosses the diagonal a == b.
  double splits[3] = {t_in, t_out, t_out};
  int segments = 1;
  const double gd = d.x() - d.y();
  if (gd != 0) {
    const double t_diag = -(a0 - b0) / gd;
    if (t_diag > t_in && t_diag < t_out) {
      splits[1] = t_diag;
      segments = 2;
    }
  }
  for (int s = 0; s < segments; ++s) {
    const double ts = splits[s];
    const double te = splits[s + 1];
    const double tm = 0.5 * (ts + te);
    const bool upper = (a0 + d.x() * tm) >= (b0 + d.y() * tm);  // triangle a >= b
    const double p = upper ? h10 - h00 : h11 - h01;
    const double q = upper ? h11 - h10 : h01 - h00;
    auto f = [&](double t) {
      return o.z() + d.z() * t - (h00 + p * (a0 + d.x() * t) + q * (b0 + d.y() * t));
    };
    const double fs = f(ts);
    const double fe = f(te);
    double t_hit;
    if (fs <= 0) {
      t_hit = ts;
    } else if (fe <= 0) {
      t_hit = ts + (te - ts) * fs / (fs - fe);
    } else {
      continue;
    }
    hit->t = t_hit;
    hit->cell_i = i;
    hit->cell_j = j;
    hit->normal = Eigen::Vector3d(-p / cell_, -q / cell_, 1.0).normalized();
    return true;
  }
  return false;
}

bool Heightfield::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                            double t_max, RayHit* hit) const {
  GLAM_CHECK(!levels_.empty(), "BuildPyramid() not called");
  // Grid coordinates: (u, v) in cells, z in metres; t stays the world distance.
  const Eigen::Vector3d o((origin.x() - origin_.x()) / cell_, (origin.y() - origin_.y()) / cell_,
                          origin.z());
  const Eigen::Vector3d d(dir.x() / cell_, dir.y() / cell_, dir.z());
  const double lo[3] = {0.0, 0.0, static_cast<double>(min_height_) - 1e-3};
  const double hi[3] = {cols_ - 1.0, rows_ - 1.0, static_cast<double>(max_height_) + 1e-3};
  double t0 = 0;
  double t1 = t_max;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (o[k] < lo[k] || o[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - o[k]) / d[k];
    double tb = (hi[k] - o[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return false;

  const int top = static_cast<int>(levels_.size()) - 1;
  const double inv_x = d.x() != 0 ? 1.0 / d.x() : kInf;
  const double inv_y = d.y() != 0 ? 1.0 / d.y() : kInf;
  int level = top;
  double t = t0;
  while (t < t1) {
    const Level& lv = levels_[level];
    const double size = static_cast<double>(1 << level);
    const double tn = t + kNudge;
    const int bi = std::clamp(static_cast<int>(std::max(o.x() + d.x() * tn, 0.0)) >> level, 0, lv.cols - 1);
    const int bj = std::clamp(static_cast<int>(std::max(o.y() + d.y() * tn, 0.0)) >> level, 0, lv.rows - 1);
    const double tx = d.x() > 0 ? ((bi + 1) * size - o.x()) * inv_x
                                : (d.x() < 0 ? (bi * size - o.x()) * inv_x : kInf);
    const double ty = d.y() > 0 ? ((bj + 1) * size - o.y()) * inv_y
                                : (d.y() < 0 ? (bj * size - o.y()) * inv_y : kInf);
    const bool exit_x = tx <= ty;
    const double t_exit = std::max(std::min({tx, ty, t1}), t + kNudge);
    const double z_low = std::min(o.z() + d.z() * t, o.z() + d.z() * t_exit);
    bool advance = false;
    if (z_low > lv.max[static_cast<std::size_t>(bj) * lv.cols + bi]) {
      advance = true;
    } else if (level > 0) {
      --level;
      continue;
    } else {
      if (IntersectCell(bi, bj, o, d, t, std::min(t_exit, t1), hit)) {
        hit->point = origin + hit->t * dir;
        return true;
      }
      advance = true;
    }
    if (advance) {
      t = t_exit;
      // Climb one level only when the step left the parent block (avoids ping-pong).
      const bool leaves_parent = exit_x ? ((d.x() > 0) == ((bi & 1) == 1))
                                        : ((d.y() > 0) == ((bj & 1) == 1));
      if (leaves_parent && level < top) ++level;
    }
  }
  return false;
}

void Heightfield::WriteGroundTruth(const std::filesystem::path& dir) const {
  static_assert(std::endian::native == std::endian::little, "gt_heights.f32 is little-endian");
  const nlohmann::json meta{{"format", "glam-heightfield"},
                            {"version", 1},
                            {"origin", {origin_.x(), origin_.y()}},
                            {"cell_size", cell_},
                            {"cols", cols_},
                            {"rows", rows_},
                            {"heights", "gt_heights.f32"}};
  {
    std::ofstream out(dir / "gt_surface.json");
    out << meta.dump(2) << "\n";
    if (!out) throw EnvironmentError("cannot write " + (dir / "gt_surface.json").string());
  }
  std::ofstream bin(dir / "gt_heights.f32", std::ios::binary);
  bin.write(reinterpret_cast<const char*>(heights_.data()),
            static_cast<std::streamsize>(heights_.size() * sizeof(float)));
  if (!bin) throw EnvironmentError("cannot write " + (dir / "gt_heights.f32").string());
}

}  // namespace glam::synth
