// The solver's own update of the wetted wall, predicted (tq/water/wall_prediction.hpp).
#include "tq/water/wall_prediction.hpp"

#include <algorithm>

namespace tq {

std::vector<Index> wallNodes(const Mesh& mesh, const std::string& face) {
  std::vector<Index> nodes = mesh.faceNodes(face);  // throws InputError naming the missing group
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  if (nodes.empty()) throw InputError("/coupling: face group '" + face + "' has no nodes");
  return nodes;
}

WallPrediction::WallPrediction(const Solver& solver, std::vector<Index> nodes)
    : solver_(solver), nodes_(std::move(nodes)), u0_(3 * nodes_.size()) {
  for (size_t k = 0; k < nodes_.size(); ++k)
    for (int d = 0; d < 3; ++d) u0_[3 * k + size_t(d)] = solver.state().u(nodes_[k], d);
}

void WallPrediction::predict(Real dt, const NodalState& st, const Real* F, WallMotion& m, bool withResponse) const {
  const bool leapfrog = solver_.options().integrator == Integrator::CentralDifference;
  const Real alpha = solver_.massDampingCoefficient();
  const Real* u = st.uData();
  const Real* v = st.vData();
  const Real* fi = st.fIntData();
  const Real* fe = st.fExtData();
  const Real* cb = st.dashpotData();
  for (size_t k = 0; k < nodes_.size(); ++k) {
    const Index n = nodes_[k];
    const Real mn = st.mass(n);
    for (int d = 0; d < 3; ++d) {
      const size_t i = dofIndex(n, d), j = 3 * k + size_t(d);
      if (!(mn > 0)) {  // node of no active element: the solver holds it at rest
        m.disp[j] = u[i] - u0_[j];
        m.vel[j] = 0;
        if (withResponse) m.respU[j] = m.respV[j] = 0;
        continue;
      }
      const Real fr = solver_.isFixed(n, d) ? 0.0 : 1.0;
      const Real f = (F ? fe[i] + F[j] : fe[i]) - fi[i], cm = alpha * mn;
      Real vn, du;
      if (leapfrog) {
        const Real mdt = mn / dt, ch = 0.5 * (cm + cb[i]);
        vn = fr * ((mdt - ch) * v[i] + f) / (mdt + ch);
        du = dt * vn;
        if (withResponse) m.respV[j] = fr / (mdt + ch), m.respU[j] = dt * m.respV[j];
      } else {
        const Real acc = fr * (f - (cm + cb[i]) * v[i]) / mn;
        du = dt * v[i] + 0.5 * dt * dt * acc;
        vn = fr * (2 * du / dt - v[i]);
        if (withResponse) m.respU[j] = fr * 0.5 * dt * dt / mn, m.respV[j] = fr * dt / mn;
      }
      m.disp[j] = (u[i] + du) - u0_[j];
      m.vel[j] = vn;
    }
  }
}

}  // namespace tq
