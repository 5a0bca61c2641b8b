// Tests of the triangular kernels against Eigen's dense results.
#include "triangular_ops.hpp"
#include "varbo/math.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::linalg;

TEST_CASE("triangular inverse and Gram matrix of a lower factor match Eigen's dense results") {
  // Sizes below, at and above the recursion's block size (48), and odd splits.
  Rng rng(11);
  for (const Index n : {1, 5, 47, 48, 49, 97, 130}) {
    Mat M(n, n);
    for (Index i = 0; i < n; ++i)
      for (Index j = 0; j < n; ++j) M(i, j) = rng.normal();
    const Mat A = M * M.transpose() + static_cast<double>(n) * Mat::Identity(n, n);
    const Eigen::LLT<Mat> llt(A);
    REQUIRE(llt.info() == Eigen::Success);
    // matrixLLT() holds garbage above the diagonal: the kernels must read the lower triangle only.
    const Mat inv = lower_triangular_inverse(llt.matrixLLT());
    const Mat L = llt.matrixL();
    const Mat ref_inv = L.triangularView<Eigen::Lower>().solve(Mat::Identity(n, n));
    CHECK((inv - ref_inv).norm() <= 1e-12 * ref_inv.norm());
    CHECK(inv.triangularView<Eigen::StrictlyUpper>().toDenseMatrix().norm() == 0.0);
    const Mat gram = lower_triangular_gram(inv);
    const Mat ref_gram = ref_inv.transpose() * ref_inv;  // = A⁻¹
    CHECK((gram - ref_gram).norm() <= 1e-12 * ref_gram.norm());
    CHECK((gram - gram.transpose()).norm() == 0.0);
    CHECK((gram * A - Mat::Identity(n, n)).norm() < 1e-10 * static_cast<double>(n));
  }
}
