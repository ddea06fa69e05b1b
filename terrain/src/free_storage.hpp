// Freeing a vector's storage before its scope ends, for the grid solvers (erosion.cpp,
// rivers.cpp) whose peak memory is a sum of per-cell arrays.
#pragma once

#include <vector>

namespace terrain {

/// Frees `v`'s storage. (`v = {}` keeps it: that assigns an empty initializer list; `clear`
/// keeps the capacity too.)
template <typename T>
void free_storage(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

}  // namespace terrain
