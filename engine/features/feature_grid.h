// Uniform grid over image positions for "which features lie within r pixels of p" queries.
// The tracker asks this once per projected landmark; a grid with cells about the search
// radius answers it by touching ~4-9 cells instead of scanning every feature.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace glam {

class FeatureGrid {
 public:
  // points: feature positions in pixels; the grid covers [0, width) x [0, height) and clamps
  // points outside into the border cells. cell_size in pixels (> 0).
  FeatureGrid(const std::vector<Eigen::Vector2d>& points, int width, int height, double cell_size);

  // Appends to *out the indices of points with ||point - center|| <= radius.
  void Query(const Eigen::Vector2d& center, double radius, std::vector<int>* out) const;

  size_t size() const { return points_.size(); }
  const Eigen::Vector2d& point(int i) const { return points_[static_cast<size_t>(i)]; }

 private:
  int CellX(double x) const;
  int CellY(double y) const;

  std::vector<Eigen::Vector2d> points_;
  double inv_cell_;
  int cols_, rows_;
  std::vector<int> cell_start_;  // CSR layout: indices of cell c are order_[start[c], start[c+1])
  std::vector<int> order_;
};

}  // namespace glam
