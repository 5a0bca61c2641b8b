#pragma once
// Local data of the critic (Algorithm 3, step c): the observations near the current policy, found with a
// nanoflann k-d tree (section 4.1.2 suggests a kd-tree with a k-nearest or ε-ball criterion).
#include <vector>

#include "varbo/types.hpp"

namespace varbo::rssgd {

struct Neighborhood {
  double radius = 0.2625;  ///< ε (unit cube, Euclidean); used when k_nearest == 0
  Index k_nearest = 0;     ///< > 0: the k nearest observations instead of the ε-ball
  Index min_points = 3;    ///< when the ε-ball holds fewer, take this many nearest instead
};

/// Row indices of X (points are rows) near `center`, sorted ascending (so the local data set does not
/// depend on the tree's traversal order).
std::vector<Index> local_indices(const Mat& X, const Vec& center, const Neighborhood& hood);

/// The rows `indices` of `data`, in that order.
Dataset subset(const Dataset& data, const std::vector<Index>& indices);

}  // namespace varbo::rssgd
