#pragma once
// Little-endian writing and bounds-checked reading of the map file's
// fields. The reader never reads past its span: a short field sets a
// sticky failure and returns zeros, and the caller reports where.

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "sitepose/core/se3.hpp"
#include "sitepose/mapfile/framed_file.hpp"

namespace sitepose::mapfile {

// The layout's constants (map_file.hpp): magic, section tags and the
// smallest encoded size of each repeated item (a count larger than the
// bytes left can hold is refused before anything is allocated).
inline constexpr std::array<std::uint8_t, 8> kMagic = {'S', 'P', 'M', 'A', 'P', '\r', '\n', 0x1a};
constexpr std::uint32_t section_tag(const char (&name)[5]) {
  return static_cast<std::uint32_t>(static_cast<std::uint8_t>(name[0])) |
         static_cast<std::uint32_t>(static_cast<std::uint8_t>(name[1])) << 8 |
         static_cast<std::uint32_t>(static_cast<std::uint8_t>(name[2])) << 16 |
         static_cast<std::uint32_t>(static_cast<std::uint8_t>(name[3])) << 24;
}
// The map file's frame (framed_file.hpp): kMagic, map_file.hpp's kFormatVersion.
const FileKind& map_file_kind();
inline constexpr std::uint32_t kMetaTag = section_tag("META");
inline constexpr std::uint32_t kKeyFramesTag = section_tag("KFRM");
inline constexpr std::uint32_t kPointsTag = section_tag("PNTS");
inline constexpr std::uint32_t kCovisibilityTag = section_tag("COVI");
inline constexpr std::uint32_t kLoopEdgesTag = section_tag("LOOP");  // optional: maps without loops lack it
inline constexpr std::uint32_t kMapTravelTag = section_tag("TRVL");  // optional: maps saved before it lack it
inline constexpr std::size_t kKeyPointBytes = 67;
inline constexpr std::size_t kKeyFrameBytes = 96;
inline constexpr std::size_t kPointBytes = 136;
inline constexpr std::size_t kObservationBytes = 12;
inline constexpr std::size_t kCovisibilityBytes = 12;
inline constexpr std::size_t kLoopEdgeBytes = 8;
inline constexpr std::size_t kMapTravelBytes = 16;

class ByteWriter {
 public:
  void u8(std::uint8_t v) { bytes_.push_back(v); }
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void raw(std::span<const std::uint8_t> b) { bytes_.insert(bytes_.end(), b.begin(), b.end()); }
  void text(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  void vec3(const Eigen::Vector3d& v) {
    for (int i = 0; i < 3; ++i) f64(v[i]);
  }
  void pose(const SE3& T) {
    const Eigen::Quaterniond& q = T.rotation();
    f64(q.w());
    f64(q.x());
    f64(q.y());
    f64(q.z());
    vec3(T.translation());
  }
  // Overwrites 8 bytes at `at` (a section length known only at its end).
  void patch_u64(std::size_t at, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes_[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  std::size_t size() const { return bytes_.size(); }
  std::vector<std::uint8_t>& bytes() { return bytes_; }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t> bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}

  bool ok() const { return ok_; }
  std::size_t remaining() const { return bytes_.size() - at_; }
  std::size_t position() const { return at_; }

  std::uint8_t u8() { return static_cast<std::uint8_t>(get(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(get(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(get(4)); }
  std::uint64_t u64() { return get(8); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  std::int64_t i64() { return static_cast<std::int64_t>(u64()); }
  double f64() { return std::bit_cast<double>(u64()); }
  std::span<const std::uint8_t> raw(std::size_t n) {
    if (!take(n)) return {};
    return bytes_.subspan(at_ - n, n);
  }
  std::string text() {
    const std::uint32_t n = u32();
    const auto b = raw(n);
    return std::string(b.begin(), b.end());
  }
  Eigen::Vector3d vec3() {
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = f64();
    return v;
  }
  SE3 pose() {
    const double w = f64();
    const double x = f64();
    const double y = f64();
    const double z = f64();
    const Eigen::Vector3d t = vec3();
    Eigen::Quaterniond q(w, x, y, z);
    // A zero quaternion (only from a broken writer) would not normalise,
    // nor would one whose norm overflows (normalized() then gives zero).
    const double norm = q.norm();
    if (!(norm > 0.5) || !std::isfinite(norm)) {
      ok_ = false;
      q = Eigen::Quaterniond::Identity();
    }
    return SE3(q.normalized(), t);
  }
  // A count of items of at least `min_item_bytes` each: refuses counts the
  // remaining bytes cannot hold, before anything is allocated for them.
  std::size_t count(std::size_t min_item_bytes) {
    const std::uint64_t n = u64();
    if (!ok_ || (min_item_bytes > 0 && n > remaining() / min_item_bytes)) {
      ok_ = false;
      return 0;
    }
    return static_cast<std::size_t>(n);
  }

 private:
  bool take(std::size_t n) {
    if (!ok_ || n > remaining()) {
      ok_ = false;
      return false;
    }
    at_ += n;
    return true;
  }
  std::uint64_t get(int n) {
    if (!take(static_cast<std::size_t>(n))) return 0;
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(bytes_[at_ - n + i]) << (8 * i);
    return v;
  }

  std::span<const std::uint8_t> bytes_;
  std::size_t at_ = 0;
  bool ok_ = true;
};

}  // namespace sitepose::mapfile
