#pragma once
// CRC-32 (IEEE 802.3, the zlib/PNG polynomial, reflected), small enough to
// keep the map file free of a compression library.

#include <cstddef>
#include <cstdint>
#include <span>

namespace sitepose::mapfile {

// CRC of `bytes` continuing from `crc` (0 for a fresh checksum).
std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

}  // namespace sitepose::mapfile
