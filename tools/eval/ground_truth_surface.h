// The true scene surface of a synthetic world, as written by `glam synth`:
//   gt_surface.json = {"format": "glam-heightfield", "version": 1, "origin": [x0, y0],
//                      "cell_size": c, "cols": W, "rows": H, "heights": "gt_heights.f32"}
//   gt_heights.f32  = W*H little-endian float32, row-major: heights[j*W + i] is z at
//                     (x0 + i*c, y0 + j*c).
// The surface is the triangle mesh of that grid, each cell split along its
// (i,j)-(i+1,j+1) diagonal. Map accuracy is the Euclidean distance of a map point to this
// mesh. A vertical difference would overstate the error next to building walls (a point on a
// facade is centimetres from the wall but metres above the ground below it), so the distance
// is the exact point-to-triangle distance, found by searching the cells around the point.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross()
#include <filesystem>
#include <string>
#include <vector>

namespace glam::eval {

struct SurfaceDistance {
  // False if the point's (x, y) lies outside the grid's footprint: the truth is unknown
  // there, so such points are counted separately instead of being scored.
  bool inside = false;
  // Exact Euclidean distance to the mesh when <= the search cap; otherwise an upper bound
  // that is itself >= the cap (see HeightfieldSurface::Distance).
  double distance = 0;
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();  // closest surface point found
};

class HeightfieldSurface {
 public:
  // Throws InputError unless cols, rows >= 2, cell_size > 0 and finite, heights has
  // cols*rows finite values.
  HeightfieldSurface(const Eigen::Vector2d& origin, double cell_size, int cols, int rows,
                     std::vector<float> heights);

  // Reads gt_surface.json and the heights file it names (relative to the JSON's folder).
  // Throws InputError naming the file for anything missing, mistyped or inconsistent.
  static HeightfieldSurface Load(const std::filesystem::path& json_path);
  // Writes gt_surface.json at `json_path` and the heights next to it under `heights_name`.
  // Throws EnvironmentError if a file cannot be written.
  void Save(const std::filesystem::path& json_path,
            const std::string& heights_name = "gt_heights.f32") const;

  // Height of the mesh at (x, y); requires Contains(x, y).
  double HeightAt(double x, double y) const;
  bool Contains(double x, double y) const;

  // Distance from p to the mesh. The search looks at all cells within a square of half-width
  // r around (p.x, p.y); a triangle outside it is > r away, so the best distance found is
  // exact once it is <= r. r starts at one cell and doubles; it never exceeds
  // max(max_search_radius, one cell). Points are usually centimetres to metres from the
  // surface, so the first one or two rounds decide.
  SurfaceDistance Distance(const Eigen::Vector3d& p, double max_search_radius = 50.0) const;

  const Eigen::Vector2d& origin() const { return origin_; }
  double cell_size() const { return cell_size_; }
  int cols() const { return cols_; }
  int rows() const { return rows_; }
  float height(int i, int j) const { return heights_[static_cast<std::size_t>(j) * cols_ + i]; }

 private:
  Eigen::Vector3d Vertex(int i, int j) const;
  // Searches cells [i0, i1] x [j0, j1] (cell (i, j) spans vertices i..i+1, j..j+1),
  // improving best/closest.
  void SearchCells(const Eigen::Vector3d& p, int i0, int i1, int j0, int j1, double& best_sq,
                   Eigen::Vector3d& closest) const;

  Eigen::Vector2d origin_;
  double cell_size_;
  int cols_;
  int rows_;
  std::vector<float> heights_;
  // Per cell min/max height: a cheap lower bound on the distance to a cell's triangles lets
  // the search skip most cells.
  std::vector<float> cell_min_;
  std::vector<float> cell_max_;
};

// Closest point to p on triangle (a, b, c) (region tests on the barycentric coordinates).
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace glam::eval
