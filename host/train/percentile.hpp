// The q-quantile of a sample by nth_element, as the training's placements read one: the
// element at floor(q (n - 1)) of the sorted values.
#pragma once

#include <algorithm>
#include <vector>

namespace nova::detail {

// 0 for an empty sample.
template <class T>
T percentile(std::vector<T> v, double q) {
  if (v.empty()) return T(0);
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(i), v.end());
  return v[i];
}

}  // namespace nova::detail
