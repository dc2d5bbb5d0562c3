// The state archive's copy (tq/core/state_archive.hpp).
#include "tq/core/state_archive.hpp"

#include <algorithm>

namespace tq {

void StateArchive::copyBytes(void* dst, const void* src, std::size_t n) {
  // The copy is bound by the memory's bandwidth, which one core does not take: a large item (a
  // nodal vector, a block's stress or history) is copied in fixed pieces by the solver's threads.
  // The bytes are the same whatever the thread count.
  constexpr std::size_t kPiece = std::size_t(1) << 17;
  const long pieces = long((n + kPiece - 1) / kPiece);
  auto* d = static_cast<unsigned char*>(dst);
  const auto* s = static_cast<const unsigned char*>(src);
#pragma omp parallel for schedule(static) if (pieces >= 4)
  for (long k = 0; k < pieces; ++k) {
    const std::size_t a = std::size_t(k) * kPiece;
    std::memcpy(d + a, s + a, std::min(kPiece, n - a));
  }
}

}  // namespace tq
