#pragma once
// End-to-end protection of the sitepose pose/quality frame: CRC-8 SAE J1850
// and a 4-bit alive counter (the scheme of AUTOSAR E2E profile 1, which uses
// the same polynomial), so the navigation ECU detects corrupt, repeated or
// stale frames. Pure functions plus one small single-threaded counter.

#include <cstdint>
#include <span>

namespace sitepose::output {

// CRC-8 SAE J1850: poly 0x1D, init 0xFF, no reflection, xor-out 0xFF.
// Check value: crc8_sae_j1850("123456789") == 0x4B.
std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> bytes);

// Continues a running CRC (before xor-out): start with kCrc8J1850Init, feed
// the pieces, finish with `^ kCrc8J1850XorOut`.
inline constexpr std::uint8_t kCrc8J1850Init = 0xFF;
inline constexpr std::uint8_t kCrc8J1850XorOut = 0xFF;
std::uint8_t crc8_sae_j1850_update(std::uint8_t crc, std::span<const std::uint8_t> bytes);

// 4-bit alive counter 0, 1, ..., 15, 0, ... One per protected message
// stream; owned by the encoder of that stream (not thread-safe).
class E2eAliveCounter {
 public:
  // Returns the value for the next frame and advances.
  std::uint8_t next() {
    const std::uint8_t v = value_;
    value_ = static_cast<std::uint8_t>((value_ + 1) & 0x0F);
    return v;
  }
  std::uint8_t peek() const { return value_; }

 private:
  std::uint8_t value_ = 0;
};

}  // namespace sitepose::output
