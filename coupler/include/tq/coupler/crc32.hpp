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

inline const std::array<std::uint32_t, 256>& table() {
  static const std::array<std::uint32_t, 256> t = [] {
    std::array<std::uint32_t, 256> a{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
      a[i] = c;
    }
    return a;
  }();
  return t;
}

/// The CRC-32 of `n` bytes, continuing `crc` (0 to start), as zlib.crc32(data, crc).
inline std::uint32_t crc32(const void* data, std::size_t n, std::uint32_t crc = 0) {
  const auto& t = table();
  const auto* b = static_cast<const unsigned char*>(data);
  std::uint32_t c = crc ^ 0xFFFFFFFFU;
  for (std::size_t i = 0; i < n; ++i) c = t[(c ^ b[i]) & 0xFFU] ^ (c >> 8);
  return c ^ 0xFFFFFFFFU;
}

/// Eight lower-case hex digits, as Python's f"{zlib.crc32(data):08x}".
inline std::string hex(std::uint32_t c) {
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(c));
  return buf;
}

}  // namespace tq::crc
