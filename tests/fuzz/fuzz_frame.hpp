#pragma once
// The binary files (map file, vocabulary) sit in a checksummed frame
// (mapfile/framed_file.hpp). Nearly every mutation of a valid file breaks
// the payload checksum, so a harness decodes the input twice: as it is (the
// frame's own checks), and reframed, which lets mutations reach the
// sections behind the checksum.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "sitepose/mapfile/crc32.hpp"
#include "sitepose/mapfile/framed_file.hpp"

namespace sitepose::fuzz {

// The input with the header's payload length and both CRCs rewritten to
// fit the bytes after it; magic, version and flags stay as they are. A
// short input is returned unchanged.
inline std::vector<std::uint8_t> reframed(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> bytes(data, data + size);
  constexpr std::size_t kHeader = mapfile::kFrameHeaderBytes;
  if (bytes.size() < kHeader) return bytes;
  const auto put = [&bytes](std::size_t at, std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i)
      bytes[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
  };
  const std::span<const std::uint8_t> all(bytes);
  put(16, bytes.size() - kHeader, 8);
  put(24, mapfile::crc32(all.subspan(kHeader)), 4);
  put(28, mapfile::crc32(all.first(kHeader - 4)), 4);
  return bytes;
}

}  // namespace sitepose::fuzz
