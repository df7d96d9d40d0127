#include "tools/eval/ground_truth_surface.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "engine/core/error.h"

namespace glam::eval {
namespace {

static_assert(std::endian::native == std::endian::little, "gt_heights.f32 is little-endian");

constexpr const char* kFormat = "glam-heightfield";
constexpr int kVersion = 1;

Eigen::Vector3d ClosestPointOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                      const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len_sq = ab.squaredNorm();
  if (len_sq <= 0) return a;
  const double s = std::clamp((p - a).dot(ab) / len_sq, 0.0, 1.0);
  return a + s * ab;
}

nlohmann::json ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open ground-truth surface {}", path.string()));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{} is not valid JSON: {}", path.string(), e.what()));
  }
}

template <typename T>
T Field(const nlohmann::json& j, const char* name, const std::filesystem::path& path) {
  if (!j.contains(name))
    throw InputError(fmt::format("{}: missing field '{}'", path.string(), name));
  try {
    return j.at(name).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(fmt::format("{}: field '{}' has the wrong type", path.string(), name));
  }
}

}  // namespace

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  // If p's projection onto the triangle's plane lies inside the triangle it is the answer;
  // otherwise the closest point lies on one of the three edges.
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double n_sq = n.squaredNorm();
  if (n_sq > 0) {
    const Eigen::Vector3d q = p - ((p - a).dot(n) / n_sq) * n;
    if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 &&
        (a - c).cross(q - c).dot(n) >= 0) {
      return q;
    }
  }
  Eigen::Vector3d best = ClosestPointOnSegment(p, a, b);
  for (const Eigen::Vector3d& candidate :
       {ClosestPointOnSegment(p, b, c), ClosestPointOnSegment(p, c, a)}) {
    if ((candidate - p).squaredNorm() < (best - p).squaredNorm()) best = candidate;
  }
  return best;
}

HeightfieldSurface::HeightfieldSurface(const Eigen::Vector2d& origin, double cell_size, int cols,
                                       int rows, std::vector<float> heights)
    : origin_(origin),
      cell_size_(cell_size),
      cols_(cols),
      rows_(rows),
      heights_(std::move(heights)) {
  if (!origin_.allFinite()) throw InputError("heightfield origin is not finite");
  if (!(cell_size_ > 0) || !std::isfinite(cell_size_)) {
    throw InputError(fmt::format("heightfield cell_size must be > 0, got {}", cell_size_));
  }
  if (cols_ < 2 || rows_ < 2) {
    throw InputError(
        fmt::format("heightfield needs at least 2x2 samples, got {}x{}", cols_, rows_));
  }
  if (heights_.size() != static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_)) {
    throw InputError(fmt::format("heightfield has {} heights, expected cols*rows = {}",
                                 heights_.size(), static_cast<std::size_t>(cols_) * rows_));
  }
  for (float h : heights_) {
    if (!std::isfinite(h)) throw InputError("heightfield contains a non-finite height");
  }
  const std::size_t cells = static_cast<std::size_t>(cols_ - 1) * (rows_ - 1);
  cell_min_.resize(cells);
  cell_max_.resize(cells);
  for (int j = 0; j + 1 < rows_; ++j) {
    for (int i = 0; i + 1 < cols_; ++i) {
      const float corners[4] = {height(i, j), height(i + 1, j), height(i, j + 1),
                                height(i + 1, j + 1)};
      const std::size_t k = static_cast<std::size_t>(j) * (cols_ - 1) + i;
      cell_min_[k] = *std::min_element(corners, corners + 4);
      cell_max_[k] = *std::max_element(corners, corners + 4);
    }
  }
}

HeightfieldSurface HeightfieldSurface::Load(const std::filesystem::path& json_path) {
  const nlohmann::json j = ReadJson(json_path);
  if (!j.is_object())
    throw InputError(fmt::format("{}: expected a JSON object", json_path.string()));
  const auto format = Field<std::string>(j, "format", json_path);
  if (format != kFormat) {
    throw InputError(
        fmt::format("{}: format is '{}', expected '{}'", json_path.string(), format, kFormat));
  }
  const auto version = Field<int>(j, "version", json_path);
  if (version != kVersion) {
    throw InputError(fmt::format("{}: version {} is not supported (this build reads {})",
                                 json_path.string(), version, kVersion));
  }
  const auto origin = Field<std::vector<double>>(j, "origin", json_path);
  if (origin.size() != 2) {
    throw InputError(fmt::format("{}: 'origin' must be [x0, y0]", json_path.string()));
  }
  const auto cell_size = Field<double>(j, "cell_size", json_path);
  const auto cols = Field<int>(j, "cols", json_path);
  const auto rows = Field<int>(j, "rows", json_path);
  if (cols < 2 || rows < 2) {
    throw InputError(
        fmt::format("{}: cols and rows must be >= 2, got {} x {}", json_path.string(), cols, rows));
  }
  const std::filesystem::path heights_path =
      json_path.parent_path() / Field<std::string>(j, "heights", json_path);

  const std::size_t count = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
  std::error_code ec;
  const auto file_size = std::filesystem::file_size(heights_path, ec);
  if (ec) throw InputError(fmt::format("cannot open heights file {}", heights_path.string()));
  if (file_size != count * sizeof(float)) {
    throw InputError(fmt::format("{} has {} bytes, expected cols*rows*4 = {}",
                                 heights_path.string(), file_size, count * sizeof(float)));
  }
  std::vector<float> heights(count);
  std::ifstream in(heights_path, std::ios::binary);
  in.read(reinterpret_cast<char*>(heights.data()),
          static_cast<std::streamsize>(count * sizeof(float)));
  if (!in) throw InputError(fmt::format("cannot read heights file {}", heights_path.string()));
  try {
    return HeightfieldSurface(Eigen::Vector2d(origin[0], origin[1]), cell_size, cols, rows,
                              std::move(heights));
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", json_path.string(), e.what()));
  }
}

void HeightfieldSurface::Save(const std::filesystem::path& json_path,
                              const std::string& heights_name) const {
  const nlohmann::json j = {
      {"format", kFormat},       {"version", kVersion}, {"origin", {origin_.x(), origin_.y()}},
      {"cell_size", cell_size_}, {"cols", cols_},       {"rows", rows_},
      {"heights", heights_name}};
  const std::filesystem::path heights_path = json_path.parent_path() / heights_name;
  std::ofstream heights_out(heights_path, std::ios::binary);
  heights_out.write(reinterpret_cast<const char*>(heights_.data()),
                    static_cast<std::streamsize>(heights_.size() * sizeof(float)));
  heights_out.close();
  std::ofstream json_out(json_path);
  json_out << j.dump(2) << "\n";
  json_out.close();
  if (!heights_out || !json_out) {
    throw EnvironmentError(fmt::format("cannot write ground-truth surface {}", json_path.string()));
  }
}

bool HeightfieldSurface::Contains(double x, double y) const {
  const double u = (x - origin_.x()) / cell_size_;
  const double v = (y - origin_.y()) / cell_size_;
  return u >= 0 && v >= 0 && u <= cols_ - 1 && v <= rows_ - 1;
}

double HeightfieldSurface::HeightAt(double x, double y) const {
  const double u = (x - origin_.x()) / cell_size_;
  const double v = (y - origin_.y()) / cell_size_;
  const int i = std::clamp(static_cast<int>(std::floor(u)), 0, cols_ - 2);
  const int j = std::clamp(static_cast<int>(std::floor(v)), 0, rows_ - 2);
  const double fu = u - i;
  const double fv = v - j;
  const double h00 = height(i, j), h10 = height(i + 1, j), h01 = height(i, j + 1),
               h11 = height(i + 1, j + 1);
  // Triangles (00, 10, 11) below the diagonal (fu >= fv) and (00, 11, 01) above it.
  if (fu >= fv) return h00 + fu * (h10 - h00) + fv * (h11 - h10);
  return h00 + fv * (h01 - h00) + fu * (h11 - h01);
}

Eigen::Vector3d HeightfieldSurface::Vertex(int i, int j) const {
  return {origin_.x() + i * cell_size_, origin_.y() + j * cell_size_, height(i, j)};
}

void HeightfieldSurface::SearchCells(const Eigen::Vector3d& p, int i0, int i1, int j0, int j1,
                                     double& best_sq, Eigen::Vector3d& closest) const {
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      // Lower bound: distance from p to the cell's bounding box.
      const double x_lo = origin_.x() + i * cell_size_, y_lo = origin_.y() + j * cell_size_;
      const double dx = std::max({0.0, x_lo - p.x(), p.x() - (x_lo + cell_size_)});
      const double dy = std::max({0.0, y_lo - p.y(), p.y() - (y_lo + cell_size_)});
      const std::size_t k = static_cast<std::size_t>(j) * (cols_ - 1) + i;
      const double dz = std::max({0.0, cell_min_[k] - p.z(), p.z() - cell_max_[k]});
      if (dx * dx + dy * dy + dz * dz >= best_sq) continue;
      const Eigen::Vector3d v00 = Vertex(i, j), v10 = Vertex(i + 1, j), v01 = Vertex(i, j + 1),
                            v11 = Vertex(i + 1, j + 1);
      for (const Eigen::Vector3d& q :
           {ClosestPointOnTriangle(p, v00, v10, v11), ClosestPointOnTriangle(p, v00, v11, v01)}) {
        const double d_sq = (q - p).squaredNorm();
        if (d_sq < best_sq) {
          best_sq = d_sq;
          closest = q;
        }
      }
    }
  }
}

SurfaceDistance HeightfieldSurface::Distance(const Eigen::Vector3d& p,
                                             double max_search_radius) const {
  SurfaceDistance result;
  if (!p.allFinite() || !Contains(p.x(), p.y())) return result;
  result.inside = true;
  const double cap = std::max(max_search_radius, cell_size_);
  double best_sq = std::numeric_limits<double>::infinity();
  auto cell_index = [this](double coordinate, double origin, int cells) {
    const double index = std::floor((coordinate - origin) / cell_size_);
    return static_cast<int>(std::clamp(index, 0.0, static_cast<double>(cells - 1)));
  };
  // Start with the cell under the point: its triangles give a tight first bound that lets
  // SearchCells skip most of the square.
  const int ic = cell_index(p.x(), origin_.x(), cols_ - 1);
  const int jc = cell_index(p.y(), origin_.y(), rows_ - 1);
  SearchCells(p, ic, ic, jc, jc, best_sq, result.closest);
  for (double r = cell_size_;; r = std::min(2 * r, cap)) {
    const int i0 = cell_index(p.x() - r, origin_.x(), cols_ - 1);
    const int i1 = cell_index(p.x() + r, origin_.x(), cols_ - 1);
    const int j0 = cell_index(p.y() - r, origin_.y(), rows_ - 1);
    const int j1 = cell_index(p.y() + r, origin_.y(), rows_ - 1);
    SearchCells(p, i0, i1, j0, j1, best_sq, result.closest);
    const bool whole_grid = i0 == 0 && j0 == 0 && i1 == cols_ - 2 && j1 == rows_ - 2;
    if (best_sq <= r * r || r >= cap || whole_grid) break;
  }
  result.distance = std::sqrt(best_sq);
  return result;
}

}  // namespace glam::eval
