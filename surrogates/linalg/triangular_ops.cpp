#include "triangular_ops.hpp"

namespace varbo::linalg {

namespace {

// Below this size Eigen's own kernels are as fast as the recursion.
constexpr Index kBlock = 48;

using MatRef = Eigen::Ref<Mat>;

/// X (holding lower L) ← L⁻¹.  [A 0; C D]⁻¹ = [A⁻¹ 0; −D⁻¹ C A⁻¹  D⁻¹]: two half-size inversions and two
/// triangular-times-dense products of (n/2)³ flops each, n³/3 in total.
void invert_lower(MatRef X) {
  const Index n = X.rows();
  if (n <= kBlock) {
    Mat inv = Mat::Identity(n, n);
    X.triangularView<Eigen::Lower>().solveInPlace(inv);
    X = inv;
    return;
  }
  const Index k = n / 2, m = n - k;
  invert_lower(X.topLeftCorner(k, k));
  invert_lower(X.bottomRightCorner(m, m));
  const Mat CA = X.bottomLeftCorner(m, k) * X.topLeftCorner(k, k).triangularView<Eigen::Lower>();
  X.bottomLeftCorner(m, k).noalias() = -(X.bottomRightCorner(m, m).triangularView<Eigen::Lower>() * CA);
  X.topRightCorner(k, m).setZero();
}

/// Lower triangle of G ← M'M for lower M.  With M = [A 0; C D]: M'M = [A'A + C'C, C'D; D'C, D'D].
void gram_lower(const Eigen::Ref<const Mat>& M, MatRef G) {
  const Index n = M.rows();
  if (n <= kBlock) {
    const Mat Ml = M.triangularView<Eigen::Lower>();
    G.setZero();
    G.selfadjointView<Eigen::Lower>().rankUpdate(Ml.transpose());
    return;
  }
  const Index k = n / 2, m = n - k;
  gram_lower(M.topLeftCorner(k, k), G.topLeftCorner(k, k));
  G.topLeftCorner(k, k).selfadjointView<Eigen::Lower>().rankUpdate(M.bottomLeftCorner(m, k).transpose());
  G.bottomLeftCorner(m, k).noalias() =
      M.bottomRightCorner(m, m).triangularView<Eigen::Lower>().transpose() * M.bottomLeftCorner(m, k);
  gram_lower(M.bottomRightCorner(m, m), G.bottomRightCorner(m, m));
}

}  // namespace

Mat lower_triangular_inverse(const Mat& L) {
  Mat X = L.triangularView<Eigen::Lower>();
  invert_lower(X);
  return X;
}

Mat lower_triangular_gram(const Mat& M) {
  Mat G(M.rows(), M.cols());
  gram_lower(M, G);
  G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
  return G;
}

}  // namespace varbo::linalg
