#include "sitepose/mapfile/framed_file.hpp"

#include <algorithm>
#include <fstream>
#include <iterator>

#include "sitepose/core/hex.hpp"
#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/crc32.hpp"

namespace sitepose::mapfile {
Unexpected refuse_file(const FileKind& kind, const std::string& why) {
  return make_error(ErrorCode::kParseError, kind.noun + " refused: " + why);
}

void write_frame_header(const FileKind& kind, std::vector<std::uint8_t>& bytes) {
  const std::span<const std::uint8_t> payload(bytes.data() + kFrameHeaderBytes,
                                              bytes.size() - kFrameHeaderBytes);
  ByteWriter header;
  header.raw(kind.magic);
  header.u32(kind.version);
  header.u32(0);
  header.u64(payload.size());
  header.u32(crc32(payload));
  header.u32(crc32(header.bytes()));
  std::copy(header.bytes().begin(), header.bytes().end(), bytes.begin());
}

Expected<std::span<const std::uint8_t>> check_frame(const FileKind& kind, std::span<const std::uint8_t> bytes,
                                                    std::uint32_t& version) {
  if (bytes.size() < kFrameHeaderBytes) {
    return refuse_file(kind, "truncated: " + std::to_string(bytes.size()) + " bytes, the header alone is " +
                                 std::to_string(kFrameHeaderBytes));
  }
  if (!std::equal(kind.magic.begin(), kind.magic.end(), bytes.begin()))
    return refuse_file(kind, "not a sitepose " + kind.noun + " (bad magic)");
  ByteReader header(bytes.subspan(kind.magic.size(), kFrameHeaderBytes - kind.magic.size()));
  version = header.u32();
  header.u32();  // flags
  const std::uint64_t payload_bytes = header.u64();
  const std::uint32_t payload_crc = header.u32();
  const std::uint32_t header_crc = header.u32();
  if (crc32(bytes.first(kFrameHeaderBytes - 4)) != header_crc)
    return refuse_file(kind, "header checksum mismatch (corrupted header)");
  if (version != kind.version) {
    return refuse_file(kind, "format version " + std::to_string(version) + ", this build reads version " +
                                 std::to_string(kind.version));
  }
  const std::uint64_t have = bytes.size() - kFrameHeaderBytes;
  if (have < payload_bytes) {
    return refuse_file(kind, "truncated: the header announces " + std::to_string(payload_bytes) +
                                 " payload bytes, the file has " + std::to_string(have));
  }
  if (have > payload_bytes) {
    return refuse_file(
        kind, std::to_string(have - payload_bytes) + " bytes after the announced end of the payload");
  }
  const auto payload = bytes.subspan(kFrameHeaderBytes);
  if (const std::uint32_t crc = crc32(payload); crc != payload_crc) {
    return refuse_file(kind, "payload checksum mismatch (stored " + hex(payload_crc, HexStyle::kChecksum) +
                                 ", computed " + hex(crc, HexStyle::kChecksum) + "): the file is corrupted");
  }
  return payload;
}

Expected<std::vector<std::uint8_t>> read_file_bytes(const FileKind& kind, const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, kind.noun + " " + path.string() + ": no such file");
  }
  std::ifstream in(path, std::ios::binary);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return make_error(ErrorCode::kIoError, kind.noun + " " + path.string() + ": cannot read");
  return bytes;
}

}  // namespace sitepose::mapfile
