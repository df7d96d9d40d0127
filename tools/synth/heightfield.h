// The synthetic world's geometry: a regular heightfield, triangulated with each cell split
// along its (i, j)-(i+1, j+1) diagonal. The renderer casts rays against exactly this surface
// and gt_surface.json / gt_heights.f32 store exactly these samples, so the ground truth is
// exact by construction. Building walls are the steep one-cell-wide triangles between a roof
// sample and a ground sample.
// Ray casting uses a max-height pyramid (each level stores the maximum of 2x2 blocks below):
// a ray segment that stays above a block's maximum skips the whole block, so even grazing
// oblique rays cost O(log n) block steps instead of one step per cell.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

namespace glam::synth {

struct RayHit {
  double t = 0;                 // distance along the (unit) ray direction
  Eigen::Vector3d point;        // world coordinates of the hit
  Eigen::Vector3d normal;       // unit normal of the hit triangle (z >= 0)
  int cell_i = 0;               // cell (i, j) containing the hit
  int cell_j = 0;
};

class Heightfield {
 public:
  Heightfield() = default;
  // Heights initialised to 0; x = origin.x + i * cell, y = origin.y + j * cell.
  Heightfield(const Eigen::Vector2d& origin, double cell_size, int cols, int rows);

  const Eigen::Vector2d& origin() const { return origin_; }
  double cell_size() const { return cell_; }
  int cols() const { return cols_; }
  int rows() const { return rows_; }
  float& at(int i, int j) { return heights_[static_cast<std::size_t>(j) * cols_ + i]; }
  float at(int i, int j) const { return heights_[static_cast<std::size_t>(j) * cols_ + i]; }
  const std::vector<float>& heights() const { return heights_; }

  // Height of the triangulated surface at (x, y); clamps to the border outside.
  double HeightAt(double x, double y) const;

  // Must be called after the heights are final and before Intersect().
  void BuildPyramid();

  // First intersection of origin + t * dir (dir unit length) with the surface, t in (0, t_max].
  bool Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_max,
                 RayHit* hit) const;

  // gt_surface.json + gt_heights.f32 (format "glam-heightfield" version 1).
  // Throws EnvironmentError when the files cannot be written.
  void WriteGroundTruth(const std::filesystem::path& dir) const;

 private:
  bool IntersectCell(int i, int j, const Eigen::Vector3d& o_grid, const Eigen::Vector3d& d_grid,
                     double t_in, double t_out, RayHit* hit) const;

  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  double cell_ = 1;
  int cols_ = 0;
  int rows_ = 0;
  std::vector<float> heights_;
  // levels_[0]: per cell max of its 4 corners, (cols-1) x (rows-1); level k: 2^k blocks.
  struct Level {
    int cols = 0;
    int rows = 0;
    std::vector<float> max;
  };
  std::vector<Level> levels_;
  float min_height_ = 0;
  float max_height_ = 0;
};

}  // namespace glam::synth
