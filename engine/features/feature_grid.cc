#include "engine/features/feature_grid.h"

#include <algorithm>
#include <cmath>

#include "engine/core/error.h"

namespace glam {

FeatureGrid::FeatureGrid(const std::vector<Eigen::Vector2d>& points, int width, int height,
                         double cell_size)
    : points_(points), inv_cell_(1.0 / cell_size) {
  GLAM_CHECK(cell_size > 0 && width > 0 && height > 0);
  cols_ = std::max(1, static_cast<int>(std::ceil(width * inv_cell_)));
  rows_ = std::max(1, static_cast<int>(std::ceil(height * inv_cell_)));
  std::vector<int> cell(points_.size());
  cell_start_.assign(static_cast<size_t>(cols_ * rows_) + 1, 0);
  for (size_t i = 0; i < points_.size(); ++i) {
    cell[i] = CellY(points_[i].y()) * cols_ + CellX(points_[i].x());
    ++cell_start_[static_cast<size_t>(cell[i]) + 1];
  }
  for (size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  order_.resize(points_.size());
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (size_t i = 0; i < points_.size(); ++i) {
    order_[static_cast<size_t>(fill[static_cast<size_t>(cell[i])]++)] = static_cast<int>(i);
  }
}

int FeatureGrid::CellX(double x) const {
  if (!(x > 0)) return 0;  // also NaN
  return std::min(cols_ - 1, static_cast<int>(x * inv_cell_));
}

int FeatureGrid::CellY(double y) const {
  if (!(y > 0)) return 0;
  return std::min(rows_ - 1, static_cast<int>(y * inv_cell_));
}

void FeatureGrid::Query(const Eigen::Vector2d& center, double radius, std::vector<int>* out) const {
  if (!center.allFinite() || !(radius >= 0)) return;
  const int x0 = CellX(center.x() - radius), x1 = CellX(center.x() + radius);
  const int y0 = CellY(center.y() - radius), y1 = CellY(center.y() + radius);
  const double r2 = radius * radius;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const size_t c = static_cast<size_t>(y * cols_ + x);
      for (int k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
        const int i = order_[static_cast<size_t>(k)];
        if ((points_[static_cast<size_t>(i)] - center).squaredNorm() <= r2) out->push_back(i);
      }
    }
  }
}

}  // namespace glam
