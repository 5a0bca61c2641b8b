#include "local_data.hpp"

#include <nanoflann.hpp>

#include <algorithm>

namespace varbo::rssgd {

namespace {
using Tree = nanoflann::KDTreeEigenMatrixAdaptor<Mat, -1, nanoflann::metric_L2, /*row_major=*/true>;

std::vector<Index> nearest(const Tree& tree, const Vec& center, Index k) {
  std::vector<Index> idx(static_cast<std::size_t>(k));
  std::vector<double> d2(static_cast<std::size_t>(k));
  const auto found = tree.index->knnSearch(center.data(), static_cast<std::size_t>(k), idx.data(), d2.data());
  idx.resize(found);
  return idx;
}
}  // namespace

std::vector<Index> local_indices(const Mat& X, const Vec& center, const Neighborhood& hood) {
  std::vector<Index> out;
  const Index n = X.rows();
  if (n == 0) return out;
  Tree tree(X.cols(), std::cref(X), 10);
  tree.index->buildIndex();
  if (hood.k_nearest > 0) {
    out = nearest(tree, center, std::min(hood.k_nearest, n));
  } else {
    // nanoflann's L2 metric works with squared distances.
    std::vector<std::pair<Index, double>> matches;
    nanoflann::SearchParams params;
    params.sorted = false;
    tree.index->radiusSearch(center.data(), hood.radius * hood.radius, matches, params);
    for (const auto& m : matches) out.push_back(m.first);
    if (static_cast<Index>(out.size()) < hood.min_points) out = nearest(tree, center, std::min(hood.min_points, n));
  }
  std::sort(out.begin(), out.end());
  return out;
}

Dataset subset(const Dataset& data, const std::vector<Index>& indices) {
  Dataset out = Dataset::empty(data.dim());
  out.X.resize(static_cast<Index>(indices.size()), data.dim());
  out.y.resize(static_cast<Index>(indices.size()));
  for (std::size_t i = 0; i < indices.size(); ++i) {
    out.X.row(static_cast<Index>(i)) = data.X.row(indices[i]);
    out.y(static_cast<Index>(i)) = data.y(indices[i]);
  }
  return out;
}

}  // namespace varbo::rssgd
