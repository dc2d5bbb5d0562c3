#pragma once
/// @file crc32.hpp
/// @brief CRC-32 (ISO-HDLC, the polynomial 0x04C11DB7 reflected; zlib's `crc32`, Python's
/// `zlib.crc32`) of restart checkpoint files, written by tq-solid and by the water's tqInterface
/// and verified before a resume (docs/formats.md "Restart checkpoints"). It detects every error of
/// up to 32 consecutive bits (one flipped bit, a torn sector's worth of bits) and a random change
/// with probability 1 - 2^-32; it guards against accidents, not against deliberate edits.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace tq::crc {

/// Slicing-by-8 tables: t[0] the byte-wise table, t[k][i] the CRC of byte i followed by k zeros.
inline const std::array<std::array<std::uint32_t, 256>, 8>& tables() {
  static const auto t = [] {
    std::array<std::array<std::uint32_t, 256>, 8> a{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
      a[0][i] = c;
    }
    for (std::uint32_t i = 0; i < 256; ++i)
      for (int k = 1; k < 8; ++k) a[k][i] = (a[k - 1][i] >> 8) ^ a[0][a[k - 1][i] & 0xFFU];
    return a;
  }();
  return t;
}

/// The CRC-32 of `n` bytes, continuing `crc` (0 to start), as zlib.crc32(data, crc); eight bytes a
/// step (slicing-by-8), the rest byte by byte.
inline std::uint32_t crc32(const void* data, std::size_t n, std::uint32_t crc = 0) {
  const auto& t = tables();
  const auto* b = static_cast<const unsigned char*>(data);
  std::uint32_t c = crc ^ 0xFFFFFFFFU;
  for (; n >= 8; n -= 8, b += 8) {
    const std::uint32_t lo =
        c ^ (std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 | std::uint32_t(b[3]) << 24);
    c = t[7][lo & 0xFFU] ^ t[6][(lo >> 8) & 0xFFU] ^ t[5][(lo >> 16) & 0xFFU] ^ t[4][lo >> 24] ^ t[3][b[4]] ^
        t[2][b[5]] ^ t[1][b[6]] ^ t[0][b[7]];
  }
  for (; n > 0; --n, ++b) c = t[0][(c ^ *b) & 0xFFU] ^ (c >> 8);
  return c ^ 0xFFFFFFFFU;
}

/// Eight lower-case hex digits, as Python's f"{zlib.crc32(data):08x}".
inline std::string hex(std::uint32_t c) {
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(c));
  return buf;
}

}  // namespace tq::crc
