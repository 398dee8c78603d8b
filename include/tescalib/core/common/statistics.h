// Robust statistics shared by the checks and the tools.
#pragma once

#include <algorithm>
#include <vector>

namespace tescalib {

/// The upper median of `v` (the element at size / 2 once sorted); 0 for an empty vector.
inline double medianOf(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace tescalib
