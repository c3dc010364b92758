#pragma once
// Physical value -> raw integer field, shared by the J1939 and NMEA 2000
// encoders: round to the resolution, clamp to the valid raw range (never
// wrap), NaN -> the "not available" code; and little-endian byte placement.

#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>

namespace sitepose::output::detail {

// The scale is given as raw counts per physical unit (1e7 for 1e-7 deg/bit):
// every resolution used here has an exact integer inverse, so multiplying in
// long double reproduces round((value - offset) / resolution) exactly even
// for the 1e-16 deg fields, where dividing by an inexact 1e-16 would not.
struct FieldSpec {
  double raw_per_unit;  // 1 / resolution
  double offset;        // physical = raw / raw_per_unit + offset
  std::int64_t min_raw;
  std::int64_t max_raw;  // largest valid raw value
  std::int64_t not_available;
};

inline std::int64_t to_raw(double value, const FieldSpec& f) {
  if (std::isnan(value)) return f.not_available;
  const long double x = (static_cast<long double>(value) - f.offset) * f.raw_per_unit;
  if (!(x > static_cast<long double>(f.min_raw))) return f.min_raw;
  if (!(x < static_cast<long double>(f.max_raw))) return f.max_raw;
  const std::int64_t r = std::llroundl(x);
  return r < f.min_raw ? f.min_raw : (r > f.max_raw ? f.max_raw : r);
}

// Writes the low `n_bytes` of `raw` (two's complement for signed fields).
inline void put_le(std::span<std::uint8_t> out, std::size_t offset, std::int64_t raw,
                   std::size_t n_bytes) {
  auto u = static_cast<std::uint64_t>(raw);
  for (std::size_t i = 0; i < n_bytes; ++i) {
    out[offset + i] = static_cast<std::uint8_t>(u & 0xFF);
    u >>= 8;
  }
}

// Angle wrapped into [0, 2 pi); NaN stays NaN.
inline double wrap_two_pi(double angle_rad) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  double a = std::fmod(angle_rad, kTwoPi);
  if (a < 0.0) a += kTwoPi;
  return a >= kTwoPi ? 0.0 : a;
}

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// J1939-71 ranges: raw values above 0xFA.. are error / not-available codes.
inline constexpr FieldSpec j1939_u8(double raw_per_unit, double off) {
  return {raw_per_unit, off, 0, 0xFA, 0xFF};
}
inline constexpr FieldSpec j1939_u16(double raw_per_unit, double off) {
  return {raw_per_unit, off, 0, 0xFAFF, 0xFFFF};
}
inline constexpr FieldSpec j1939_u32(double raw_per_unit, double off) {
  return {raw_per_unit, off, 0, 0xFAFFFFFFLL, 0xFFFFFFFFLL};
}

// NMEA 2000: the top three codes are out-of-range, reserved, not-available.
inline constexpr FieldSpec n2k_u8(double raw_per_unit) {
  return {raw_per_unit, 0.0, 0, 0xFC, 0xFF};
}
inline constexpr FieldSpec n2k_u16(double raw_per_unit) {
  return {raw_per_unit, 0.0, 0, 0xFFFC, 0xFFFF};
}
inline constexpr FieldSpec n2k_u32(double raw_per_unit) {
  return {raw_per_unit, 0.0, 0, 0xFFFFFFFCLL, 0xFFFFFFFFLL};
}
inline constexpr FieldSpec n2k_i16(double raw_per_unit) {
  return {raw_per_unit, 0.0, -0x7FFF, 0x7FFC, 0x7FFF};
}
inline constexpr FieldSpec n2k_i32(double raw_per_unit) {
  return {raw_per_unit, 0.0, -0x7FFFFFFFLL, 0x7FFFFFFCLL, 0x7FFFFFFFLL};
}
inline constexpr FieldSpec n2k_i64(double raw_per_unit) {
  return {raw_per_unit, 0.0, -0x7FFFFFFFFFFFFFFFLL, 0x7FFFFFFFFFFFFFFCLL, 0x7FFFFFFFFFFFFFFFLL};
}

}  // namespace sitepose::output::detail
