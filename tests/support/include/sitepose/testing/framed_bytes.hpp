#pragma once
// A framed file's bytes (mapfile/framed_file.hpp: map files, vocabularies)
// with the header refitted after a test changed them: magic and version as
// the bytes say, flags 0, payload length and both checksums recomputed, so
// the test reaches the check behind the checksums (a version, a value).
// Needs sitepose::mapfile.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "sitepose/mapfile/framed_file.hpp"

namespace sitepose::testing {

inline void refit_frame(std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < mapfile::kFrameHeaderBytes) return;
  mapfile::FileKind kind;
  std::copy_n(bytes.begin(), kind.magic.size(), kind.magic.begin());
  for (int i = 0; i < 4; ++i) kind.version |= std::uint32_t{bytes[kind.magic.size() + i]} << (8 * i);
  mapfile::write_frame_header(kind, bytes);
}

}  // namespace sitepose::testing
