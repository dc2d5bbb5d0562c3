// The eigen-decomposition of symmetric 3x3 matrices (materials/eigen_sym3.hpp).
#pragma GCC diagnostic ignored "-Wpsabi"  // the AVX helpers are always inlined: no ABI crosses them
#include "materials/eigen_sym3.hpp"

#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>

namespace tq {

// Cyclic Jacobi eigen-decomposition of a symmetric 3x3 matrix (accurate also for close or
// repeated eigenvalues; each rotation in the cheap form of Rutishauser, with τ = s/(1 + c)).
// On exit eval ascending and evec[:, i] (column i) its unit eigenvector.
void eigenSym3(const Real s[6], Real eval[3], Real evec[3][3]) {
  Real A[3][3] = {{s[XX], s[XY], s[ZX]}, {s[XY], s[YY], s[YZ]}, {s[ZX], s[YZ], s[ZZ]}};
  Real V[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  auto rotate = [&](int p, int q, int r) {
    const Real apq = A[p][q];
    if (apq == 0) return;
    const Real theta = (A[q][q] - A[p][p]) / (2 * apq);
    const Real t = (theta >= 0 ? 1 : -1) / (std::abs(theta) + std::sqrt(theta * theta + 1));
    const Real c = 1 / std::sqrt(t * t + 1), sn = t * c, tau = sn / (1 + c);
    A[p][p] -= t * apq;
    A[q][q] += t * apq;
    A[p][q] = A[q][p] = 0;
    const Real arp = A[r][p], arq = A[r][q];
    A[r][p] = A[p][r] = arp - sn * (arq + tau * arp);
    A[r][q] = A[q][r] = arq + sn * (arp - tau * arq);
    for (int k = 0; k < 3; ++k) {
      const Real vkp = V[k][p], vkq = V[k][q];
      V[k][p] = vkp - sn * (vkq + tau * vkp);
      V[k][q] = vkq + sn * (vkp - tau * vkq);
    }
  };
  for (int sweep = 0; sweep < 50; ++sweep) {
    const Real off = A[0][1] * A[0][1] + A[0][2] * A[0][2] + A[1][2] * A[1][2];
    const Real diag = A[0][0] * A[0][0] + A[1][1] * A[1][1] + A[2][2] * A[2][2];
    if (off <= 1e-34 * diag || off == 0) break;
    rotate(0, 1, 2);
    rotate(0, 2, 1);
    rotate(1, 2, 0);
  }
  int o[3] = {0, 1, 2};
  if (A[o[1]][o[1]] < A[o[0]][o[0]]) std::swap(o[0], o[1]);
  if (A[o[2]][o[2]] < A[o[1]][o[1]]) std::swap(o[1], o[2]);
  if (A[o[1]][o[1]] < A[o[0]][o[0]]) std::swap(o[0], o[1]);
  for (int i = 0; i < 3; ++i) {
    eval[i] = A[o[i]][o[i]];
    for (int k = 0; k < 3; ++k) evec[k][i] = V[k][o[i]];
  }
}

namespace {

typedef Real JV __attribute__((vector_size(32)));
typedef long long JM __attribute__((vector_size(32)));

__attribute__((target("avx2"), always_inline)) inline bool anyLane(JM m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }
// One rotation of eigenSym3's in the lanes `live` whose pivot A[p][q] is not 0.
__attribute__((target("avx2"), always_inline)) inline void rotateX4(JV (&A)[3][3], JV (&V)[3][3], int p, int q, int r,
                                                                    JM live) {
  const JV one = {1, 1, 1, 1}, zero = {0, 0, 0, 0};
  const JM magnitude = {0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL};
  const JV apq = A[p][q];
  const JM go = live & (apq != 0);
  if (!anyLane(go)) return;
  const JV a = go ? apq : one;  // idle lanes: finite values, discarded below
  const JV theta = (A[q][q] - A[p][p]) / (2 * a);
  const JV absTheta = JV(JM(theta) & magnitude);
  const JV t = (theta >= 0 ? one : -one) / (absTheta + __builtin_ia32_sqrtpd256(theta * theta + 1));
  const JV c = 1 / __builtin_ia32_sqrtpd256(t * t + 1), sn = t * c, tau = sn / (1 + c);
  A[p][p] = go ? A[p][p] - t * a : A[p][p];
  A[q][q] = go ? A[q][q] + t * a : A[q][q];
  A[p][q] = A[q][p] = go ? zero : A[p][q];
  const JV arp = A[r][p], arq = A[r][q];
  A[r][p] = A[p][r] = go ? arp - sn * (arq + tau * arp) : arp;
  A[r][q] = A[q][r] = go ? arq + sn * (arp - tau * arq) : arq;
  for (int k = 0; k < 3; ++k) {
    const JV vkp = V[k][p], vkq = V[k][q];
    V[k][p] = go ? vkp - sn * (vkq + tau * vkp) : vkp;
    V[k][q] = go ? vkq + sn * (vkp - tau * vkq) : vkq;
  }
}
}  // namespace

// eigenSym3 on 4 matrices at once, s[q][l] component q (Voigt) of matrix l: AVX2 without FMA, every
// lane the scalar code's operations in its order (its sweeps and rotations, a lane done or with a
// zero pivot left as it is), so each lane's result is eigenSym3's bit for bit. The Jacobi's chain
// of square roots and divisions is latency-bound; four lanes share it.
__attribute__((target("avx2"))) void eigenSym3x4(const Real (*s)[4], Real eval[4][3], Real evec[4][3][3]) {
  const JV one = {1, 1, 1, 1}, zero = {0, 0, 0, 0};
  JV c[6];
  for (int q = 0; q < 6; ++q) c[q] = JV{s[q][0], s[q][1], s[q][2], s[q][3]};
  JV A[3][3] = {{c[XX], c[XY], c[ZX]}, {c[XY], c[YY], c[YZ]}, {c[ZX], c[YZ], c[ZZ]}};
  JV V[3][3] = {{one, zero, zero}, {zero, one, zero}, {zero, zero, one}};
  JM live = one == one;
  for (int sweep = 0; sweep < 50; ++sweep) {
    const JV off = A[0][1] * A[0][1] + A[0][2] * A[0][2] + A[1][2] * A[1][2];
    const JV diag = A[0][0] * A[0][0] + A[1][1] * A[1][1] + A[2][2] * A[2][2];
    live = live & ~((off <= 1e-34 * diag) | (off == 0));
    if (!anyLane(live)) break;
    rotateX4(A, V, 0, 1, 2, live);
    rotateX4(A, V, 0, 2, 1, live);
    rotateX4(A, V, 1, 2, 0, live);
  }
  for (int l = 0; l < 4; ++l) {
    int o[3] = {0, 1, 2};
    if (A[o[1]][o[1]][l] < A[o[0]][o[0]][l]) std::swap(o[0], o[1]);
    if (A[o[2]][o[2]][l] < A[o[1]][o[1]][l]) std::swap(o[1], o[2]);
    if (A[o[1]][o[1]][l] < A[o[0]][o[0]][l]) std::swap(o[0], o[1]);
    for (int i = 0; i < 3; ++i) {
      eval[l][i] = A[o[i]][o[i]][l];
      for (int k = 0; k < 3; ++k) evec[l][k][i] = V[k][o[i]][l];
    }
  }
}

bool eigenSym3x4Available() {
  const char* env = std::getenv("TQ_SOLID_SIMD");
  if (env && std::string(env) == "generic") return false;
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}

}  // namespace tq
