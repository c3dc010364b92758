// The vocabulary's file (layout in vocabulary.hpp) and its id.

#include <cmath>
#include <cstdio>

#include "sitepose/mapfile/atomic_file.hpp"
#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/crc32.hpp"
#include "sitepose/mapfile/framed_file.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace sitepose::placerec {
namespace {

constexpr std::size_t kNodeBytes = 32 + 1 + 8;

const mapfile::FileKind& vocabulary_kind() {
  static const mapfile::FileKind kind{
      {'S', 'P', 'V', 'O', 'C', 'A', 'B', 0x1a}, kVocabularyFormatVersion, "vocabulary file"};
  return kind;
}

}  // namespace

std::vector<std::uint8_t> Vocabulary::encode_payload() const {
  mapfile::ByteWriter out;
  out.u32(static_cast<std::uint32_t>(branching_));
  out.u32(static_cast<std::uint32_t>(levels_));
  out.u64(training_images_);
  out.u64(nodes_.size());
  for (const Node& n : nodes_) {
    out.raw(n.centre);
    out.u8(n.children);
    out.f64(n.idf);
  }
  return std::move(out.bytes());
}

std::string Vocabulary::make_id() const {
  char text[64];
  std::snprintf(text, sizeof(text), "orb-kmajority-%dx%d-%08x", branching_, levels_,
                mapfile::crc32(encode_payload()));
  return text;
}

std::vector<std::uint8_t> Vocabulary::encode() const {
  std::vector<std::uint8_t> bytes(mapfile::kFrameHeaderBytes, 0);
  const std::vector<std::uint8_t> payload = encode_payload();
  bytes.insert(bytes.end(), payload.begin(), payload.end());
  mapfile::write_frame_header(vocabulary_kind(), bytes);
  return bytes;
}

Expected<Vocabulary> Vocabulary::decode(std::span<const std::uint8_t> bytes) {
  const mapfile::FileKind& kind = vocabulary_kind();
  std::uint32_t version = 0;
  SITEPOSE_TRY(const auto payload, mapfile::check_frame(kind, bytes, version));
  mapfile::ByteReader in(payload);
  Vocabulary v;
  v.branching_ = static_cast<int>(in.u32());
  v.levels_ = static_cast<int>(in.u32());
  v.training_images_ = in.u64();
  const std::size_t n = in.count(kNodeBytes);
  if (!in.ok() || v.branching_ < 2 || v.branching_ > 64 || v.levels_ < 1 || v.levels_ > 8 || n == 0) {
    return mapfile::refuse_file(kind, "bad parameters (branching, levels or node count)");
  }
  v.nodes_.resize(n);
  // An idf is ln(N / n) for 1 <= n <= N training images: 0, or between
  // ln(N / (N - 1)) and ln(N). Outside that, one huge or subnormal idf
  // turns the other words' normalised weights into 0, inf or NaN.
  const auto images = static_cast<double>(v.training_images_);
  const double max_idf = images > 1.0 ? std::log(images) * (1.0 + 1e-9) : 0.0;
  const double min_idf = images > 1.0 ? std::log1p(1.0 / (images - 1.0)) * (1.0 - 1e-9) : 0.0;
  std::uint64_t next_child = 1;
  for (std::size_t i = 0; i < n; ++i) {
    Node& node = v.nodes_[i];
    const auto centre = in.raw(32);
    if (!in.ok()) break;
    std::copy(centre.begin(), centre.end(), node.centre.begin());
    node.children = in.u8();
    node.idf = in.f64();
    node.first_child = static_cast<std::uint32_t>(next_child);
    next_child += node.children;
    // Children after their parent and inside the file: the tree walk ends.
    if (node.children > v.branching_ || next_child > n || (node.children > 0 && node.first_child <= i) ||
        !(node.idf == 0.0 || (node.idf >= min_idf && node.idf <= max_idf))) {
      return mapfile::refuse_file(kind, "node " + std::to_string(i) + " is not part of a valid tree");
    }
  }
  if (!in.ok() || in.remaining() != 0 || next_child != n) {
    return mapfile::refuse_file(kind, "the node list does not form one tree");
  }
  v.finish();
  return v;
}

Status Vocabulary::save(const std::filesystem::path& path) const {
  return mapfile::write_file_atomically(path, encode());
}

Expected<Vocabulary> Vocabulary::load(const std::filesystem::path& path) {
  SITEPOSE_TRY(const std::vector<std::uint8_t> bytes, mapfile::read_file_bytes(vocabulary_kind(), path));
  auto loaded = decode(bytes);
  if (!loaded) return make_error(loaded.error().code, path.string() + ": " + loaded.error().message);
  return loaded;
}

}  // namespace sitepose::placerec
