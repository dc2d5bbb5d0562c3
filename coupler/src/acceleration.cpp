// Fixed-point accelerations: none, constant relaxation, Aitken, IQN-ILS.
#include "tq/coupler/acceleration.hpp"

#include <cmath>

#include "tq/coupler/errors.hpp"

namespace tq::coupler {

namespace {
void checkSizes(const std::vector<double>& x, const std::vector<double>& xt) {
  if (x.size() != xt.size())
    throw ConfigError("acceleration: input and output sizes differ (" + std::to_string(x.size()) + " vs " +
                      std::to_string(xt.size()) + ")");
}
}  // namespace

void NoAcceleration::next(const std::vector<double>& x, const std::vector<double>& xt, std::vector<double>& out) {
  checkSizes(x, xt);
  out = xt;
}

ConstantRelaxation::ConstantRelaxation(double omega) : omega_(omega) {
  if (!(omega > 0 && omega <= 1)) throw ConfigError("relaxation factor must be in (0, 1]");
}
void ConstantRelaxation::next(const std::vector<double>& x, const std::vector<double>& xt, std::vector<double>& out) {
  checkSizes(x, xt);
  out.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) out[i] = x[i] + omega_ * (xt[i] - x[i]);
}

Aitken::Aitken(double w0) : omega0_(w0), omega_(w0) {
  if (!(w0 > 0 && w0 <= 1)) throw ConfigError("Aitken initial relaxation must be in (0, 1]");
}
void Aitken::startWindow() {
  first_ = true;
  omega_ = omega0_;
}
void Aitken::next(const std::vector<double>& x, const std::vector<double>& xt, std::vector<double>& out) {
  checkSizes(x, xt);
  const std::size_t n = x.size();
  std::vector<double> r(n);
  for (std::size_t i = 0; i < n; ++i) r[i] = xt[i] - x[i];
  if (first_) {
    omega_ = omega0_;
    first_ = false;
  } else {
    std::vector<ExactSum> sum(2);  // r_{k−1}ᵀ(r_k − r_{k−1}), ‖r_k − r_{k−1}‖²
    for (std::size_t i = 0; i < n; ++i) {
      const double dr = r[i] - rPrev_[i];
      sum[0].addProduct(rPrev_[i], dr);
      sum[1].addProduct(dr, dr);
    }
    sums().combine(sum);
    const double num = sum[0].value(), den = sum[1].value();
    if (den > 0) omega_ = -omega_ * num / den;
    // A factor of either sign is allowed (Aitken); cap its size so that a near-zero
    // denominator cannot throw the iterate far away.
    omega_ = std::max(-10.0, std::min(10.0, omega_));
  }
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = x[i] + omega_ * r[i];
  rPrev_ = std::move(r);
}

IqnIls::IqnIls(double w0, double eps, int reuse) : omega0_(w0), eps_(eps), reuse_(reuse) {
  if (!(w0 > 0 && w0 <= 1)) throw ConfigError("IQN-ILS initial relaxation must be in (0, 1]");
  if (reuse < 0) throw ConfigError("IQN-ILS reuse must be >= 0 windows");
}
void IqnIls::dropColumn(std::size_t j) {
  dr_.erase(dr_.begin() + std::ptrdiff_t(j));
  dxt_.erase(dxt_.begin() + std::ptrdiff_t(j));
  colWindow_.erase(colWindow_.begin() + std::ptrdiff_t(j));
  if (j < gram_.size()) {
    gram_.erase(gram_.begin() + std::ptrdiff_t(j));
    for (std::size_t i = j; i < gram_.size(); ++i) gram_[i].erase(gram_[i].begin() + std::ptrdiff_t(j));
  }
}
void IqnIls::startWindow() {
  first_ = true;
  ++window_;
  // Keep the columns of the last reuse_ windows (none: a fresh start each window).
  while (!dr_.empty() && colWindow_.front() + std::uint64_t(reuse_) < window_) dropColumn(0);
}
void IqnIls::next(const std::vector<double>& x, const std::vector<double>& xt, std::vector<double>& out) {
  checkSizes(x, xt);
  const std::size_t n = x.size();
  if (total_ == 0) total_ = sums().total(n);  // the values of every part
  std::vector<double> r(n);
  for (std::size_t i = 0; i < n; ++i) r[i] = xt[i] - x[i];
  out.resize(n);
  bool added = false;
  if (!first_) {
    std::vector<double> a(n), b(n);
    for (std::size_t i = 0; i < n; ++i) {
      a[i] = r[i] - rPrev_[i];
      b[i] = xt[i] - xtPrev_[i];
    }
    dr_.push_back(std::move(a));
    dxt_.push_back(std::move(b));
    colWindow_.push_back(window_);
    added = true;
    if (dr_.size() > total_) dropColumn(0), added = dr_.size() > gram_.size();  // never more columns than unknowns
  }
  rPrev_ = r;
  xtPrev_ = xt;
  const bool fresh = first_ && reuse_ == 0;
  first_ = false;
  if (fresh || dr_.empty()) {
    for (std::size_t i = 0; i < n; ++i) out[i] = x[i] + omega0_ * r[i];
    return;
  }
  // One combined sum a pass: the new column's products with every column (a new row of VᵀV),
  // and Vᵀr.
  std::size_t m = dr_.size();
  const std::size_t row = added ? m : 0;
  std::vector<ExactSum> sum(row + m);
  if (added)
    for (std::size_t j = 0; j < m; ++j) {
      ExactSum& s = sum[j];
      const std::vector<double>& a = dr_.back();
      const std::vector<double>& c = dr_[j];
      for (std::size_t i = 0; i < n; ++i) s.addProduct(a[i], c[i]);
    }
  for (std::size_t j = 0; j < m; ++j) {
    ExactSum& s = sum[row + j];
    const std::vector<double>& c = dr_[j];
    for (std::size_t i = 0; i < n; ++i) s.addProduct(c[i], r[i]);
  }
  sums().combine(sum);
  if (added) {
    std::vector<double> g(m);
    for (std::size_t j = 0; j < m; ++j) g[j] = sum[j].value();
    gram_.push_back(std::move(g));
  }
  std::vector<double> vr(m);  // Vᵀr, oldest column first
  for (std::size_t j = 0; j < m; ++j) vr[j] = sum[row + j].value();
  auto G = [&](std::size_t i, std::size_t j) { return i >= j ? gram_[i][j] : gram_[j][i]; };
  // Least squares min ‖V α + r‖ through R of V = QR (Cholesky of VᵀV) with the QR2 filter
  // (Haelterman et al. 2016): the columns newest first, a column whose part orthogonal to the
  // newer ones is below eps × its own norm carries no new information (only round-off, or a
  // Jacobian that has since changed) and is dropped, one at a time, until R is well conditioned.
  for (;;) {
    m = dr_.size();
    std::vector<double> R(m * m, 0.0);  // R(i, j) = R[i * m + j], column j = dr_[m − 1 − j]
    std::size_t bad = m;
    for (std::size_t j = 0; j < m && bad == m; ++j) {
      const std::size_t cj = m - 1 - j;
      for (std::size_t i = 0; i < j; ++i) {
        double s = G(m - 1 - i, cj);
        for (std::size_t l = 0; l < i; ++l) s -= R[l * m + i] * R[l * m + j];
        R[i * m + j] = s / R[i * m + i];
      }
      const double norm2 = G(cj, cj);
      double s = norm2;
      for (std::size_t l = 0; l < j; ++l) s -= R[l * m + j] * R[l * m + j];
      if (!(norm2 > 0) || !(s > 0) || s < eps_ * eps_ * norm2)
        bad = j;
      else
        R[j * m + j] = std::sqrt(s);
    }
    if (bad < m) {
      const std::size_t c = m - 1 - bad;
      dropColumn(c);
      vr.erase(vr.begin() + std::ptrdiff_t(c));
      if (dr_.empty()) {
        for (std::size_t i = 0; i < n; ++i) out[i] = x[i] + omega0_ * r[i];
        return;
      }
      continue;
    }
    std::vector<double> alpha(m);  // Rᵀ z = −Vᵀr, then R α = z
    for (std::size_t j = 0; j < m; ++j) {
      double s = -vr[m - 1 - j];
      for (std::size_t i = 0; i < j; ++i) s -= R[i * m + j] * alpha[i];
      alpha[j] = s / R[j * m + j];
    }
    for (std::size_t j = m; j-- > 0;) {
      double s = alpha[j];
      for (std::size_t i = j + 1; i < m; ++i) s -= R[j * m + i] * alpha[i];
      alpha[j] = s / R[j * m + j];
    }
    for (std::size_t i = 0; i < n; ++i) {
      double s = xt[i];
      for (std::size_t j = 0; j < m; ++j) s += dxt_[m - 1 - j][i] * alpha[j];
      out[i] = s;
    }
    return;
  }
}

std::unique_ptr<Acceleration> makeAcceleration(AccelerationKind k, double w0, int reuse) {
  switch (k) {
    case AccelerationKind::None:
      return std::make_unique<NoAcceleration>();
    case AccelerationKind::Constant:
      return std::make_unique<ConstantRelaxation>(w0);
    case AccelerationKind::Aitken:
      return std::make_unique<Aitken>(w0);
    case AccelerationKind::IqnIls:
      return std::make_unique<IqnIls>(w0, kIqnIlsFilter, reuse);
  }
  throw ConfigError("unknown acceleration");
}

}  // namespace tq::coupler
