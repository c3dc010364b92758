#include "sitepose/output/e2e.hpp"

namespace sitepose::output {

std::uint8_t crc8_sae_j1850_update(std::uint8_t crc, std::span<const std::uint8_t> bytes) {
  for (const std::uint8_t b : bytes) {
    crc ^= b;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x80) ? static_cast<std::uint8_t>((crc << 1) ^ 0x1D)
                         : static_cast<std::uint8_t>(crc << 1);
    }
  }
  return crc;
}

std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> bytes) {
  return crc8_sae_j1850_update(kCrc8J1850Init, bytes) ^ kCrc8J1850XorOut;
}

}  // namespace sitepose::output
