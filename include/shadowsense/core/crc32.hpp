// CRC-32 (IEEE 802.3, the one zlib.crc32 and Python's zlib compute): the checksum of the model
// file and the calibration file. It detects truncation and bit flips, not tampering.
//
// crc32(bytes) -> the CRC-32 of the bytes (crc32 of nothing is 0).
//   ensures: equals zlib.crc32(bytes); a table of 256 words built at compile time.
// Threading: a pure function.
#pragma once

#include <shadowsense/core/version.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

inline std::uint32_t crc32(std::span<const std::uint8_t> bytes) {
  static constexpr auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) c = table[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
