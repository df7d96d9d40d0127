// The median the engine uses everywhere (focal estimate, parallax, depth scales): the upper
// median, element n / 2 of the sorted values, found by partial sort (std::nth_element, O(n)).
// It is always one of the values, never an average of two.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace glam {

// Upper median of `values` (taken by value: partially reordered); 0 when empty.
inline double UpperMedian(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace glam
