#include "tq/core/nodal_state.hpp"

namespace tq {

void NodalState::resize(Index n) {
  n_ = n;
  const size_t n3 = 3 * size_t(n);
  for (auto* v : {&x0_, &u_, &v_, &a_, &fInt_, &fExt_, &c_}) v->assign(n3, 0.0);
  m_.assign(size_t(n), 0.0);
  hasDashpots_ = false;
  ++massVersion_;
  ++dashpotVersion_;
}

}  // namespace tq
