#pragma once
// Disjoint sets over the indices of a parent array (parent[r] == r at a root), the one
// union-find of core/: region merging in plane labelling, tile merging in segmentation.

#include <algorithm>
#include <numeric>
#include <span>

namespace shapesense {

/// The root of i's set; halves the path on the way, so later finds are shorter.
inline int findRoot(std::span<int> parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

/// Joins the sets of a and b under the smaller root, so a set's root is its smallest index
/// and labels derived from roots do not depend on the order of the joins.
inline void unite(std::span<int> parent, int a, int b) {
  a = findRoot(parent, a);
  b = findRoot(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

/// Makes every index its own set.
inline void resetSets(std::span<int> parent) { std::iota(parent.begin(), parent.end(), 0); }

}  // namespace shapesense
