#pragma once
// The checksummed frame shared by sitepose's binary files (map files,
// vocabularies): a 32-byte header — 8-byte magic, u32 version, u32 flags
// (0), u64 payload bytes, u32 CRC-32 of the payload, u32 CRC-32 of the
// header's first 28 bytes — then the payload. Checking names the first
// failure: size, magic, header checksum, version, length, payload checksum.

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::mapfile {

inline constexpr std::size_t kFrameHeaderBytes = 32;

struct FileKind {
  std::array<std::uint8_t, 8> magic{};
  std::uint32_t version = 0;
  std::string noun;  // "map file": in messages ("map file refused: ...")
};

// A kParseError "<noun> refused: <why>".
Unexpected refuse_file(const FileKind& kind, const std::string& why);

// `bytes` starts with kFrameHeaderBytes placeholder bytes, then the
// payload; fills the header in.
void write_frame_header(const FileKind& kind, std::vector<std::uint8_t>& bytes);

// The payload of a framed file; `version` gets the header's version (also
// when it is refused for it).
Expected<std::span<const std::uint8_t>> check_frame(const FileKind& kind, std::span<const std::uint8_t> bytes,
                                                    std::uint32_t& version);

// The whole file's bytes; kNotFound / kIoError "<noun> <path>: ...".
Expected<std::vector<std::uint8_t>> read_file_bytes(const FileKind& kind, const std::filesystem::path& path);

}  // namespace sitepose::mapfile
