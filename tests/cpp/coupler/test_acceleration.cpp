// Accelerations of the fixed point x = H(x) on linear model problems with known solutions.
#include <gtest/gtest.h>

#include <cmath>

#include "tq/coupler/acceleration.hpp"

using namespace tq::coupler;

namespace {

/// H(x) = A x + b, A = diag(a) rotated by a fixed orthogonal mix: plain iteration diverges
/// when any |a| > 1; the fixed point is (I − A)^{-1} b.
struct Linear {
  std::vector<std::vector<double>> A;
  std::vector<double> b;
  std::vector<double> operator()(const std::vector<double>& x) const {
    std::vector<double> y(b);
    for (std::size_t i = 0; i < b.size(); ++i)
      for (std::size_t j = 0; j < b.size(); ++j) y[i] += A[i][j] * x[j];
    return y;
  }
};

Linear addedMassLike(int n) {
  // Eigenvalues −7, −3.5, −1, −0.2, 0.5 (the added-mass ratios of rigid and ovaling modes
  // of ARCHITECTURE.md §5 give −14 and −7 for a one-pass exchange), mixed by a Householder
  // reflection Q = I − 2 v vᵀ / vᵀv.
  std::vector<double> lam = {-7, -3.5, -1, -0.2, 0.5};
  std::vector<double> v(n);
  for (int i = 0; i < n; ++i) v[i] = 1.0 + i;
  double vv = 0;
  for (double x : v) vv += x * x;
  Linear L;
  L.A.assign(n, std::vector<double>(n, 0));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      double s = 0;
      for (int k = 0; k < n; ++k) {
        const double qik = (i == k) - 2 * v[i] * v[k] / vv;
        const double qjk = (j == k) - 2 * v[j] * v[k] / vv;
        s += qik * lam[k] * qjk;
      }
      L.A[i][j] = s;
    }
  L.b = {1, -2, 3, 0.5, -1};
  return L;
}

double residual(const Linear& H, const std::vector<double>& x) {
  const auto y = H(x);
  double d = 0, n = 0;
  for (std::size_t i = 0; i < x.size(); ++i) d += (y[i] - x[i]) * (y[i] - x[i]), n += y[i] * y[i];
  return std::sqrt(d / n);
}

int iterate(Acceleration& acc, const Linear& H, int maxIt, double tol, std::vector<double>& x) {
  acc.startWindow();
  x.assign(H.b.size(), 0.0);
  for (int k = 0; k < maxIt; ++k) {
    if (residual(H, x) < tol) return k;
    std::vector<double> next;
    acc.next(x, H(x), next);
    x = next;
  }
  return -1;
}

}  // namespace

TEST(Acceleration, PlainIterationDivergesOnTheAddedMassProblem) {
  const Linear H = addedMassLike(5);
  NoAcceleration none;
  std::vector<double> x;
  EXPECT_EQ(iterate(none, H, 30, 1e-10, x), -1);
  double norm = 0;
  for (double v : x) norm = std::max(norm, std::abs(v));
  EXPECT_GT(norm, 1e20);  // grows like 7^k: 7^30 ~ 2e25
}

TEST(Acceleration, AitkenSolvesAScalarLinearFixedPointInTwoSteps) {
  // x = −7 x + 8 (fixed point 1): plain iteration diverges; Aitken's second factor is the
  // exact 1/(1 + 7).
  Linear H{{{-7.0}}, {8.0}};
  Aitken a(0.5);
  std::vector<double> x;
  const int k = iterate(a, H, 10, 1e-13, x);
  EXPECT_GE(k, 1);
  EXPECT_LE(k, 3);
  EXPECT_NEAR(x[0], 1.0, 1e-12);
  EXPECT_NEAR(a.lastRelaxation(), 1.0 / 8.0, 1e-12);
}

TEST(Acceleration, IqnIlsSolvesAnNDimensionalLinearProblemInNPlusTwoSteps) {
  const Linear H = addedMassLike(5);
  IqnIls q(0.1);
  std::vector<double> x;
  const int k = iterate(q, H, 20, 1e-10, x);
  ASSERT_GE(k, 0) << "IQN-ILS did not converge";
  EXPECT_LE(k, 5 + 2);  // like GMRES: n + 1 secant updates after the relaxed first step
  EXPECT_LT(residual(H, x), 1e-10);
}

TEST(Acceleration, ConstantRelaxationConvergesWhenTheFactorIsSmallEnough) {
  // Contraction factor |1 − ω(1 − λ)| for λ = −7: ω = 0.2 gives 0.6 < 1.
  Linear H{{{-7.0}}, {8.0}};
  ConstantRelaxation c(0.2);
  std::vector<double> x;
  EXPECT_GT(iterate(c, H, 200, 1e-12, x), 0);
  EXPECT_NEAR(x[0], 1.0, 1e-11);
  ConstantRelaxation tooLarge(0.5);  // |1 − 0.5·8| = 3: diverges
  EXPECT_EQ(iterate(tooLarge, H, 40, 1e-12, x), -1);
}

TEST(Acceleration, IqnIlsDropsANearDuplicateSecantColumnInsteadOfLeapingAway) {
  // A pass whose residual change nearly repeats the previous one (Δr₂ = Δr₁ + 1e-7 e_y) while
  // the answer differs (Δx̃₂ ≠ Δx̃₁: an inexactly solved, nonlinear partner) makes V nearly rank
  // one; the least squares then puts coefficients of order 1/1e-7 on two inconsistent columns.
  // The QR2 filter (docs/coupler.md "IQN-ILS filter") drops the older column and the step stays
  // of the size of the residual (|r| = 2.2); a filter relative to ‖V‖ at 1e-10 keeps both and
  // throws the iterate 5e6 away.
  auto step = [](double eps, std::size_t& columns) {
    IqnIls q(0.5, eps, 0);
    q.startWindow();
    std::vector<double> out;
    auto pass = [&](std::vector<double> r, std::vector<double> xt) {
      std::vector<double> x{xt[0] - r[0], xt[1] - r[1]};
      q.next(x, xt, out);
    };
    pass({1, 0}, {1, 0});            // the window's relaxed first step
    pass({0, 1}, {1, 1});            // column Δr = (−1, 1), Δx̃ = (0, 1)
    pass({-1, 2 + 1e-7}, {1, 1.5});  // Δr = (−1, 1 + 1e-7), Δx̃ = (0, 0.5)
    columns = q.columns();
    return std::hypot(out[0] - 1.0, out[1] - 1.5);
  };
  std::size_t cols = 0;
  EXPECT_LT(step(kIqnIlsFilter, cols), 10.0);
  EXPECT_EQ(cols, 1u);
  EXPECT_GT(step(1e-10, cols), 1e5);  // why the filter: the unfiltered least squares leaps
  EXPECT_EQ(cols, 2u);
}
