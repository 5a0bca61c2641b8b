#include "vhgp_bound.hpp"

#include <cmath>
#include <utility>

#include "triangular_ops.hpp"

namespace varbo::vhgp {

using linalg::lower_triangular_gram;
using linalg::lower_triangular_inverse;

namespace {

// The diagonal rescaling constant of vhgpr.m: S = diag(1/sqrt(p + r)) conditions the Cholesky of K_f + R
// when r is very large or small; the bound does not depend on it (vhgp.md, section 4).
constexpr double kScaleOffset = 1e-3;
const double kLog2Pi = std::log(2.0 * M_PI);

/// Everything of the stable evaluation order (vhgp.md, section 4) that the value, the gradient and the
/// predictive share.
struct Factors {
  JitteredKernel kf, kg;  // the kernels at θ_f, θ_g
  Mat Kf, Kg;
  Vec lambda, s, beta, mu, r, sc, rs, alphas, alpha, sigma_diag;
  Mat cinvB;   // L_B⁻¹ (lower), B = I + Λ^{½} K_g Λ^{½} = L_B L_B'
  Mat cinvBs;  // L_B⁻¹ Λ^{½}
  Mat Sigma;   // (K_g⁻¹ + Λ)⁻¹ = K_g − H'H, H = L_B⁻¹ Λ^{½} K_g (full: the Λ-gradient needs Σ∘Σ)
  Eigen::LLT<Mat> lltA;  // S(K_f + R)S = L L'
  double F = 0;
};

bool factorize(const VhgpBound& bound, const VhgpParams& p, bool full_sigma, Factors& f, std::string& error) {
  const Mat& X = bound.X();
  const Vec& y = bound.y();
  const Index n = y.size();
  if (p.log_lambda.size() != n || p.theta_f.size() != bound.num_f() || p.theta_g.size() != bound.num_g()) {
    error = "parameter sizes do not match the data and kernels";
    return false;
  }
  if (!p.log_lambda.allFinite() || !p.theta_f.allFinite() || !p.theta_g.allFinite() || !std::isfinite(p.mu0)) {
    error = "non-finite parameters";
    return false;
  }
  f.kf = JitteredKernel(bound.f_form(), p.theta_f, bound.jitter());
  f.kg = JitteredKernel(bound.g_form(), p.theta_g, bound.jitter());
  f.Kf = f.kf.training_matrix(X);
  f.Kg = f.kg.training_matrix(X);
  const Mat& Kg = f.Kg;

  f.lambda = p.log_lambda.array().exp();
  f.s = f.lambda.array().sqrt();
  // B = I + Λ^{½} K_g Λ^{½} has eigenvalues ≥ 1, so this Cholesky is stable where K_g⁻¹ is not (vhgp.md §9).
  Mat B = f.s.asDiagonal() * Kg * f.s.asDiagonal();
  B.diagonal().array() += 1.0;
  Eigen::LLT<Mat> lltB(B);
  if (lltB.info() != Eigen::Success || !B.allFinite()) {
    error = "Cholesky of B = I + Λ^½ K_g Λ^½ failed";
    return false;
  }
  f.cinvB = lower_triangular_inverse(lltB.matrixLLT());
  f.cinvBs = f.cinvB * f.s.asDiagonal();

  f.beta = f.lambda.array() - 0.5;
  f.mu = (Kg * f.beta).array() + p.mu0;

  const Mat H = f.cinvBs.triangularView<Eigen::Lower>() * Kg;
  if (full_sigma) {
    f.Sigma = Kg;
    f.Sigma.selfadjointView<Eigen::Lower>().rankUpdate(H.transpose(), -1.0);
    f.Sigma.triangularView<Eigen::StrictlyUpper>() = f.Sigma.transpose();
    f.sigma_diag = f.Sigma.diagonal();
  } else {
    f.sigma_diag = Kg.diagonal() - H.colwise().squaredNorm().transpose();
  }

  f.r = (f.mu - 0.5 * f.sigma_diag).array().exp();
  f.sc = (kScaleOffset + f.r.array()).rsqrt();
  f.rs = f.r.array() / (kScaleOffset + f.r.array());
  Mat A = f.sc.asDiagonal() * f.Kf * f.sc.asDiagonal();
  A.diagonal() += f.rs;
  if (!A.allFinite()) {
    error = "non-finite S(K_f + R)S";
    return false;
  }
  f.lltA.compute(A);
  if (f.lltA.info() != Eigen::Success) {
    error = "Cholesky of S(K_f + R)S failed";
    return false;
  }
  f.alphas = f.lltA.solve(y.cwiseProduct(f.sc));
  f.alpha = f.alphas.cwiseProduct(f.sc);

  const double log_diag_a = f.lltA.matrixLLT().diagonal().array().log().sum();
  const double log_diag_cinvb = f.cinvB.diagonal().array().log().sum();
  // log N(y | 0, K_f + R): log|K_f + R| = 2 Σ log diag(L_A) − 2 Σ log sc.
  const double log_lik = -0.5 * y.dot(f.alpha) - log_diag_a + f.sc.array().log().sum() - 0.5 * n * kLog2Pi;
  // −KL = −½[tr B⁻¹ + β'K_gβ − n + log|B|]: tr B⁻¹ = ‖L_B⁻¹‖², −½ log|B| = Σ log diag L_B⁻¹.
  const double minus_kl = -0.5 * f.beta.dot((f.mu.array() - p.mu0).matrix()) + log_diag_cinvb - 0.5 * f.cinvB.squaredNorm() +
                          0.5 * n;
  f.F = log_lik + minus_kl - 0.25 * f.sigma_diag.sum();
  if (!std::isfinite(f.F)) {
    error = "non-finite bound";
    return false;
  }
  return true;
}

}  // namespace

VhgpBound::VhgpBound(Mat X, Vec y, const VhgpKernels& kernels)
    : X_(std::move(X)),
      y_(std::move(y)),
      f_(kernels.f.build(X_.cols())),
      g_(kernels.g.build(X_.cols())),
      jitter_(kernels.jitter) {}

BoundValue VhgpBound::evaluate(const VhgpParams& p, bool with_gradient) const {
  BoundValue out;
  Factors f;
  if (!factorize(*this, p, with_gradient, f, out.error)) return out;
  out.ok = true;
  out.F = f.F;
  if (!with_gradient) return out;

  const Index n = size();
  // (S(K_f + R)S)⁻¹ = L⁻ᵀ L⁻¹ (symmetric; built from the triangular inverse).
  const Mat invA = lower_triangular_gram(lower_triangular_inverse(f.lltA.matrixLLT()));

  // β̂ = ∂ log N(y|0,K_f+R)/∂μ = ½ r(α² − [(K_f+R)⁻¹]_ii)  (vhgp.md §5, the code's form)
  const Vec betahat = (-0.5 * (invA.diagonal() - f.alphas.cwiseAbs2())).cwiseProduct(f.rs);
  const Vec lambdahat = betahat.array() + 0.5;

  VhgpGradient& g = out.gradient;
  // ∂F/∂Λ = −(K_g + ½ Σ∘Σ)(Λ − Λ̂): the fixed-point form, stationary at Λ = Λ̂ (L-G & T 2011, eq. 10)
  g.lambda = -(f.Kg + 0.5 * f.Sigma.cwiseAbs2()) * (f.lambda - lambdahat);
  g.log_lambda = f.lambda.cwiseProduct(g.lambda);

  // ∂F/∂θ_f = ½ Σ W_f ∘ ∂K_f,  W_f = αα' − (K_f + R)⁻¹,  (K_f + R)⁻¹ = S invA S  (the jitter term included)
  const Mat Wf = f.alpha * f.alpha.transpose() - f.sc.asDiagonal() * invA * f.sc.asDiagonal();
  g.theta_f = f.kf.contract_gradient(X_, Wf);

  // ∂F/∂θ_g = ½ Σ W_g ∘ ∂K_g with Λ held fixed (vhgp.md §5):
  //   W_g = ββ' + 2(β̂ − β)β' − invBs' diag(Λ̂/Λ − 1) invBs − cinvBs'cinvBs,   invBs = B⁻¹Λ^{½}.
  // With P = B⁻¹ = L_B⁻ᵀ L_B⁻¹ (one symmetric rank update): cinvBs'cinvBs = Λ^{½} P Λ^{½} and
  // invBs' D invBs = Λ^{½} (P D P) Λ^{½}, which saves two of the three n³ products of the direct form.
  // P D P is symmetric: only its lower triangle is computed (half the flops of the general product).
  const Mat P = lower_triangular_gram(f.cinvB);
  const Vec d = lambdahat.cwiseQuotient(f.lambda).array() - 1.0;
  const Mat PD = P * d.asDiagonal();
  Mat PDP(n, n);
  PDP.triangularView<Eigen::Lower>() = PD * P;
  PDP.triangularView<Eigen::Lower>() += P;
  PDP.triangularView<Eigen::StrictlyUpper>() = PDP.transpose();
  // Only the symmetric part of W_g counts (∂K_g is symmetric), and a kernel's contraction expects a symmetric W:
  // 2(β̂ − β)β' enters as uβ' + βu', u = β̂ − β.
  const Vec u = betahat - f.beta;
  Mat Wg = f.beta * f.beta.transpose() + u * f.beta.transpose() + f.beta * u.transpose();
  Wg.noalias() -= f.s.asDiagonal() * PDP * f.s.asDiagonal();
  g.theta_g = f.kg.contract_gradient(X_, Wg);

  // ∂F/∂μ0 = Σ β̂_i
  g.mu0 = betahat.sum();
  if (!g.log_lambda.allFinite() || !g.theta_f.allFinite() || !g.theta_g.allFinite() || !std::isfinite(g.mu0)) {
    out.ok = false;
    out.error = "non-finite gradient";
  }
  return out;
}

VhgpPosterior VhgpPosterior::condition(const VhgpBound& bound, const VhgpParams& p, BoundValue* result) {
  VhgpPosterior post;
  Factors f;
  BoundValue local;
  BoundValue& res = result ? *result : local;
  res = BoundValue{};
  if (!factorize(bound, p, false, f, res.error)) return post;
  res.ok = true;
  res.F = f.F;
  post.valid_ = true;
  post.X_ = bound.X();
  post.params_ = p;
  post.kf_ = std::move(f.kf);
  post.kg_ = std::move(f.kg);
  post.alpha_ = std::move(f.alpha);
  post.sc_ = std::move(f.sc);
  post.beta_ = std::move(f.beta);
  post.mu_ = std::move(f.mu);
  post.sigma_diag_ = std::move(f.sigma_diag);
  post.chol_a_ = f.lltA.matrixL();
  post.cinv_bs_ = std::move(f.cinvBs);
  return post;
}

LatentPrediction VhgpPosterior::predict(const Vec& x, bool with_gradient) const {
  LatentPrediction out;
  const Vec kf = kf_.cross_vec(x, X_);
  const Vec kg = kg_.cross_vec(x, X_);
  out.a = kf.dot(alpha_);
  // c*² = k** − ‖L⁻¹(S k_f*)‖²  (L L' = S(K_f+R)S)
  const Vec v = chol_a_.triangularView<Eigen::Lower>().solve(sc_.cwiseProduct(kf));
  // k** includes the kernel's own diagonal terms: σ²(1 + jitter) as covSEisoj, a white term's σ² (vhgp.md §6).
  out.c2 = kf_.prior_variance(x) - v.squaredNorm();
  out.mu = kg.dot(beta_) + params_.mu0;
  // σ*² = k** − ‖L_B⁻¹ Λ^{½} k_g*‖²  = k** − k_g*'(K_g + Λ⁻¹)⁻¹ k_g*
  const Vec w = cinv_bs_.triangularView<Eigen::Lower>() * kg;
  out.s2 = kg_.prior_variance(x) - w.squaredNorm();
  if (!with_gradient) return out;
  const Mat Gf = kf_.cross_gradient_x(x, X_);  // D × n, column i = ∂k_f(x, x_i)/∂x
  const Mat Gg = kg_.cross_gradient_x(x, X_);
  out.d_a = Gf * alpha_;
  // ∂c*²/∂x = ∂k**/∂x − 2 Gf (K_f+R)⁻¹ k_f* = ∂k**/∂x − 2 Gf S L⁻ᵀ v  (∂k**/∂x = 0 for stationary kernels)
  const Vec u = chol_a_.triangularView<Eigen::Lower>().transpose().solve(v);
  out.d_c2 = kf_.prior_variance_gradient(x) - 2.0 * Gf * sc_.cwiseProduct(u);
  out.d_mu = Gg * beta_;
  out.d_s2 = kg_.prior_variance_gradient(x) - 2.0 * Gg * (cinv_bs_.triangularView<Eigen::Lower>().transpose() * w);
  return out;
}

}  // namespace varbo::vhgp
