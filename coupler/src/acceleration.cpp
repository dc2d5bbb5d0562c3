// Fixed-point accelerations: none, constant relaxation, Aitken, IQN-ILS.
#include "tq/coupler/acceleration.hpp"

#include <Eigen/Dense>
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
    double num = 0, den = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double dr = r[i] - rPrev_[i];
      num += rPrev_[i] * dr;
      den += dr * dr;
    }
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
  std::vector<double> r(n);
  for (std::size_t i = 0; i < n; ++i) r[i] = xt[i] - x[i];
  out.resize(n);
  if (!first_) {
    std::vector<double> a(n), b(n);
    for (std::size_t i = 0; i < n; ++i) {
      a[i] = r[i] - rPrev_[i];
      b[i] = xt[i] - xtPrev_[i];
    }
    dr_.push_back(std::move(a));
    dxt_.push_back(std::move(b));
    colWindow_.push_back(window_);
    if (dr_.size() > n) dropColumn(0);  // never more columns than unknowns
  }
  rPrev_ = r;
  xtPrev_ = xt;
  const bool fresh = first_ && reuse_ == 0;
  first_ = false;
  if (fresh || dr_.empty()) {
    for (std::size_t i = 0; i < n; ++i) out[i] = x[i] + omega0_ * r[i];
    return;
  }
  Eigen::VectorXd rv = Eigen::Map<const Eigen::VectorXd>(r.data(), Eigen::Index(n));
  // Least squares min ‖V α + r‖ by QR with the QR2 filter (Haelterman et al. 2016): the columns
  // newest first, a column whose part orthogonal to the newer ones is below eps × its own norm
  // carries no new information (only round-off, or a Jacobian that has since changed) and is
  // dropped, one at a time, until R is well conditioned.
  for (;;) {
    const Eigen::Index m = Eigen::Index(dr_.size());
    Eigen::MatrixXd V(Eigen::Index(n), m);
    for (Eigen::Index j = 0; j < m; ++j)  // column j = dr_[m − 1 − j]: newest first
      V.col(j) = Eigen::Map<const Eigen::VectorXd>(dr_[std::size_t(m - 1 - j)].data(), Eigen::Index(n));
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(V);
    const Eigen::MatrixXd R = qr.matrixQR().topRows(m).triangularView<Eigen::Upper>();
    Eigen::Index bad = -1;
    for (Eigen::Index j = 0; j < m && bad < 0; ++j) {
      const double norm = V.col(j).norm();
      if (!(norm > 0) || std::abs(R(j, j)) < eps_ * norm) bad = j;
    }
    if (bad >= 0) {
      dropColumn(std::size_t(m - 1 - bad));
      if (dr_.empty()) {
        for (std::size_t i = 0; i < n; ++i) out[i] = x[i] + omega0_ * r[i];
        return;
      }
      continue;
    }
    const Eigen::VectorXd alpha = qr.solve(Eigen::VectorXd(-rv));
    for (std::size_t i = 0; i < n; ++i) {
      double s = xt[i];
      for (Eigen::Index j = 0; j < m; ++j) s += dxt_[std::size_t(m - 1 - j)][i] * alpha(j);
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
