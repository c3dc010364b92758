#pragma once
// The protocol between siteposed and sitepose-detector-host, the child
// process that runs a detector plugin so that its crash or hang cannot end
// the daemon (issue 20; docs/detect/README.md, "Crash isolation").
//
// Transport: one AF_UNIX SOCK_SEQPACKET socket pair (one message per
// packet, EOF when the peer dies) and one memfd shared by both. The frame's
// pixels travel in the memfd (kShm* offsets below, rows packed: stride =
// width); the small things travel in messages: the plugin's path and
// config, the raw sp_detection array (validated by the parent, never
// trusted), error texts. A segment() mask comes back in the memfd.
//
// A message: a 16-byte header {magic "SPDH", version, type, payload bytes,
// call id}, little-endian like the machine (both ends run on one host),
// then the payload, fields written one by one (no struct padding crosses).
// Version: kProtocolVersion; a message of another version is refused and
// names both. The host answers each request with the reply of the same
// call id; the parent discards replies of other ids (a late answer).
//
// Requests and replies, in order:
//   Init    -> Ready       once, after the host starts: dlopen, ABI check,
//                          create(); Ready carries the status and caps.
//   Detect  -> Detections  per frame: the plugin's rc, *count and the
//                          first min(count, capacity) raw detections.
//   Segment -> Segmented   when the parent wants pixel masks.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/detect/plugin_abi.h"

namespace sitepose::detector_host {

inline constexpr std::uint32_t kMagic = 0x48445053u;  // "SPDH" read as little-endian bytes
inline constexpr std::uint16_t kProtocolVersion = 1;
inline constexpr std::size_t kHeaderBytes = 16;
inline constexpr std::size_t kMaxMessageBytes = std::size_t{1} << 20;
inline constexpr std::int32_t kMaxDetections = 4096;  // per message
inline constexpr std::size_t kMaxTextBytes = 1024;    // an error text
inline constexpr std::size_t kMaxConfigBytes = 512 * 1024;
inline constexpr std::int32_t kMaxImageSide = 16384;  // px

enum class MessageType : std::uint16_t {
  kInit = 1,
  kReady = 2,
  kDetect = 3,
  kDetections = 4,
  kSegment = 5,
  kSegmented = 6,
};

struct Init {
  std::string plugin_path;
  std::string config_yaml;
};

struct Ready {
  std::int32_t status = 0;  // 0: the plugin is created and answers; else ready_status(code)
  std::uint32_t capabilities = 0;
  std::string error;  // when status != 0
};

// A stereo frame in the memfd.
struct FrameRef {
  std::int64_t seq = 0;
  std::int64_t t_ns = 0;
  std::int32_t width = 0;
  std::int32_t height = 0;
};

struct DetectRequest {
  FrameRef frame;
  std::int32_t capacity = 0;  // detections the plugin may write
};

struct DetectReply {
  std::int32_t rc = 0;
  std::int32_t count = 0;                // what the plugin wrote in *count
  std::vector<sp_detection> detections;  // the first min(count, capacity)
  std::string error;                     // when rc != 0
};

struct SegmentRequest {
  FrameRef frame;
  std::vector<sp_detection> detections;
};

struct SegmentReply {
  std::int32_t rc = 0;  // 0: the mask is in the memfd at kShmMaskOffset
  std::string error;
};

// Ready::status of a failed start, and back: the loader's ErrorCode.
std::int32_t ready_status(ErrorCode code);
ErrorCode ready_error_code(std::int32_t status);

using Message = std::variant<Init, Ready, DetectRequest, DetectReply, SegmentRequest, SegmentReply>;

struct Envelope {
  std::uint32_t call_id = 0;
  Message message;
};

std::vector<std::uint8_t> encode(const Envelope& envelope);

// kParseError naming what is wrong: short header, other magic, other
// version (both named), unknown type, a payload shorter or longer than the
// header says or than its fields, sizes beyond the limits above.
Expected<Envelope> decode(std::span<const std::uint8_t> bytes);

MessageType type_of(const Message& message);
const char* to_string(MessageType type);

// The memfd's layout for a width x height frame: left, right (8-bit), then
// the uint16 mask, each with packed rows.
std::uint64_t shm_left_offset(const FrameRef& f);
std::uint64_t shm_right_offset(const FrameRef& f);
std::uint64_t shm_mask_offset(const FrameRef& f);
std::uint64_t shm_bytes(const FrameRef& f);

// ---- transport over the socket (both ends) ---------------------------------

// One whole message; MSG_NOSIGNAL (a dead peer is an error, never SIGPIPE).
Status send_message(int fd, const Envelope& envelope);

enum class ReceiveOutcome { kMessage, kClosed, kTimeout };
struct Received {
  ReceiveOutcome outcome = ReceiveOutcome::kClosed;
  Envelope envelope;
};

// Waits at most timeout_ms (< 0: forever) for one message. kClosed: the
// peer closed or died (EOF, ECONNRESET). Errors: a message that does not
// decode, or a receive that fails otherwise.
Expected<Received> receive_message(int fd, int timeout_ms);

}  // namespace sitepose::detector_host
