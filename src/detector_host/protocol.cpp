#include "sitepose/detector_host/protocol.hpp"

#include <poll.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <type_traits>

namespace sitepose::detector_host {
namespace {

// Appends fields in the machine's byte order (both ends share the machine).
class Writer {
 public:
  template <typename T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void put_text(const std::string& text) {
    put(static_cast<std::uint32_t>(text.size()));
    bytes_.insert(bytes_.end(), text.begin(), text.end());
  }
  void put_detection(const sp_detection& d) {
    bytes_.insert(bytes_.end(), d.class_name, d.class_name + SP_CLASS_NAME_LEN);
    put(d.score);
    put(d.x);
    put(d.y);
    put(d.w);
    put(d.h);
    put(d.instance);
  }
  void put_frame(const FrameRef& f) {
    put(f.seq);
    put(f.t_ns);
    put(f.width);
    put(f.height);
  }
  std::vector<std::uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

// Reads fields back; any read past the end marks the reader failed.
class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    T value{};
    if (!take(sizeof(T))) return value;
    std::memcpy(&value, bytes_.data() + at_ - sizeof(T), sizeof(T));
    return value;
  }
  std::string get_text(std::size_t limit, const char* what) {
    const auto n = get<std::uint32_t>();
    if (n > limit)
      return fail(std::string(what) + " of " + std::to_string(n) + " bytes (limit " + std::to_string(limit) +
                  ")");
    if (!take(n)) return {};
    return {reinterpret_cast<const char*>(bytes_.data() + at_ - n), n};
  }
  sp_detection get_detection() {
    sp_detection d{};
    if (take(SP_CLASS_NAME_LEN))
      std::memcpy(d.class_name, bytes_.data() + at_ - SP_CLASS_NAME_LEN, SP_CLASS_NAME_LEN);
    d.score = get<float>();
    d.x = get<std::int32_t>();
    d.y = get<std::int32_t>();
    d.w = get<std::int32_t>();
    d.h = get<std::int32_t>();
    d.instance = get<std::uint16_t>();
    return d;
  }
  std::vector<sp_detection> get_detections() {
    const auto n = get<std::int32_t>();
    if (n < 0 || n > kMaxDetections) {
      fail(std::to_string(n) + " detections (limit " + std::to_string(kMaxDetections) + ")");
      return {};
    }
    std::vector<sp_detection> out;
    for (std::int32_t i = 0; i < n && ok(); ++i) out.push_back(get_detection());
    return out;
  }
  FrameRef get_frame() {
    FrameRef f;
    f.seq = get<std::int64_t>();
    f.t_ns = get<std::int64_t>();
    f.width = get<std::int32_t>();
    f.height = get<std::int32_t>();
    if (ok() && (f.width < 1 || f.height < 1 || f.width > kMaxImageSide || f.height > kMaxImageSide)) {
      fail("frame size " + std::to_string(f.width) + "x" + std::to_string(f.height));
    }
    return f;
  }
  bool ok() const { return error_.empty(); }
  bool at_end() const { return at_ == bytes_.size(); }
  const std::string& error() const { return error_; }
  std::string fail(std::string why) {
    if (error_.empty()) error_ = std::move(why);
    return {};
  }

 private:
  bool take(std::size_t n) {
    if (!ok()) return false;
    if (bytes_.size() - at_ < n) {
      fail("payload ends early");
      return false;
    }
    at_ += n;
    return true;
  }
  std::span<const std::uint8_t> bytes_;
  std::size_t at_ = 0;
  std::string error_;
};

void write_payload(Writer& w, const Message& message) {
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, Init>) {
          w.put_text(m.plugin_path);
          w.put_text(m.config_yaml);
        } else if constexpr (std::is_same_v<T, Ready>) {
          w.put(m.status);
          w.put(m.capabilities);
          w.put_text(m.error);
        } else if constexpr (std::is_same_v<T, DetectRequest>) {
          w.put_frame(m.frame);
          w.put(m.capacity);
        } else if constexpr (std::is_same_v<T, DetectReply>) {
          w.put(m.rc);
          w.put(m.count);
          w.put(static_cast<std::int32_t>(m.detections.size()));
          for (const sp_detection& d : m.detections) w.put_detection(d);
          w.put_text(m.error);
        } else if constexpr (std::is_same_v<T, SegmentRequest>) {
          w.put_frame(m.frame);
          w.put(static_cast<std::int32_t>(m.detections.size()));
          for (const sp_detection& d : m.detections) w.put_detection(d);
        } else {
          w.put(m.rc);
          w.put_text(m.error);
        }
      },
      message);
}

Message read_payload(Reader& r, MessageType type) {
  switch (type) {
    case MessageType::kInit: {
      Init m;
      m.plugin_path = r.get_text(4096, "plugin path");
      m.config_yaml = r.get_text(kMaxConfigBytes, "plugin config");
      return m;
    }
    case MessageType::kReady: {
      Ready m;
      m.status = r.get<std::int32_t>();
      m.capabilities = r.get<std::uint32_t>();
      m.error = r.get_text(kMaxTextBytes, "error text");
      return m;
    }
    case MessageType::kDetect: {
      DetectRequest m;
      m.frame = r.get_frame();
      m.capacity = r.get<std::int32_t>();
      if (r.ok() && (m.capacity < 1 || m.capacity > kMaxDetections)) {
        r.fail("capacity " + std::to_string(m.capacity));
      }
      return m;
    }
    case MessageType::kDetections: {
      DetectReply m;
      m.rc = r.get<std::int32_t>();
      m.count = r.get<std::int32_t>();
      m.detections = r.get_detections();
      m.error = r.get_text(kMaxTextBytes, "error text");
      return m;
    }
    case MessageType::kSegment: {
      SegmentRequest m;
      m.frame = r.get_frame();
      m.detections = r.get_detections();
      return m;
    }
    case MessageType::kSegmented: {
      SegmentReply m;
      m.rc = r.get<std::int32_t>();
      m.error = r.get_text(kMaxTextBytes, "error text");
      return m;
    }
  }
  r.fail("unknown message type");
  return Init{};
}

Error parse_error(const std::string& why) {
  return Error{ErrorCode::kParseError, "detector host protocol: " + why};
}

}  // namespace

MessageType type_of(const Message& message) {
  return static_cast<MessageType>(message.index() + 1);  // variant order = type numbers
}

const char* to_string(MessageType type) {
  switch (type) {
    case MessageType::kInit: return "init";
    case MessageType::kReady: return "ready";
    case MessageType::kDetect: return "detect";
    case MessageType::kDetections: return "detections";
    case MessageType::kSegment: return "segment";
    case MessageType::kSegmented: return "segmented";
  }
  return "unknown";
}

std::int32_t ready_status(ErrorCode code) { return 1 + static_cast<std::int32_t>(code); }

ErrorCode ready_error_code(std::int32_t status) {
  const std::int32_t code = status - 1;
  if (code < 0 || code > static_cast<std::int32_t>(ErrorCode::kRuntime)) return ErrorCode::kRuntime;
  return static_cast<ErrorCode>(code);
}

std::vector<std::uint8_t> encode(const Envelope& envelope) {
  Writer w;
  w.put(kMagic);
  w.put(kProtocolVersion);
  w.put(static_cast<std::uint16_t>(type_of(envelope.message)));
  w.put(std::uint32_t{0});  // payload bytes, filled in below
  w.put(envelope.call_id);
  write_payload(w, envelope.message);
  std::vector<std::uint8_t>& bytes = w.bytes();
  const auto payload = static_cast<std::uint32_t>(bytes.size() - kHeaderBytes);
  std::memcpy(bytes.data() + 8, &payload, sizeof(payload));
  return std::move(bytes);
}

Expected<Envelope> decode(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderBytes) {
    return Unexpected{parse_error("message of " + std::to_string(bytes.size()) + " bytes, shorter than its " +
                                  std::to_string(kHeaderBytes) + "-byte header")};
  }
  Reader header(bytes.first(kHeaderBytes));
  const auto magic = header.get<std::uint32_t>();
  const auto version = header.get<std::uint16_t>();
  const auto type = header.get<std::uint16_t>();
  const auto payload = header.get<std::uint32_t>();
  Envelope out;
  out.call_id = header.get<std::uint32_t>();
  if (magic != kMagic) return Unexpected{parse_error("not a detector host message (bad magic)")};
  if (version != kProtocolVersion) {
    return Unexpected{parse_error("version " + std::to_string(version) + ", this sitepose speaks " +
                                  std::to_string(kProtocolVersion) +
                                  " (siteposed and sitepose-detector-host from different builds?)")};
  }
  if (type < 1 || type > std::variant_size_v<Message>) {
    return Unexpected{parse_error("unknown message type " + std::to_string(type))};
  }
  if (payload != bytes.size() - kHeaderBytes) {
    return Unexpected{parse_error("header says " + std::to_string(payload) + " payload bytes, message has " +
                                  std::to_string(bytes.size() - kHeaderBytes) + " (truncated?)")};
  }
  const auto message_type = static_cast<MessageType>(type);
  Reader r(bytes.subspan(kHeaderBytes));
  out.message = read_payload(r, message_type);
  if (r.ok() && !r.at_end()) r.fail("bytes left after the payload");
  if (!r.ok()) return Unexpected{parse_error(std::string(to_string(message_type)) + ": " + r.error())};
  return out;
}

std::uint64_t shm_left_offset(const FrameRef&) { return 0; }
std::uint64_t shm_right_offset(const FrameRef& f) {
  return static_cast<std::uint64_t>(f.width) * static_cast<std::uint64_t>(f.height);
}
std::uint64_t shm_mask_offset(const FrameRef& f) { return 2 * shm_right_offset(f); }
std::uint64_t shm_bytes(const FrameRef& f) { return 4 * shm_right_offset(f); }

Status send_message(int fd, const Envelope& envelope) {
  const std::vector<std::uint8_t> bytes = encode(envelope);
  if (bytes.size() > kMaxMessageBytes) {
    return make_error(ErrorCode::kInvalidArgument, "detector host protocol: message of " +
                                                       std::to_string(bytes.size()) + " bytes is too large");
  }
  for (;;) {
    const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(bytes.size())) return ok_status();
    if (n < 0 && errno == EINTR) continue;
    return make_error(ErrorCode::kIoError, std::string("detector host: send failed: ") +
                                               (n < 0 ? std::strerror(errno) : "short send"));
  }
}

Expected<Received> receive_message(int fd, int timeout_ms) {
  using Clock = std::chrono::steady_clock;
  const auto until = Clock::now() + std::chrono::milliseconds(timeout_ms < 0 ? 0 : timeout_ms);
  for (;;) {
    int wait_ms = -1;
    if (timeout_ms >= 0) {
      const auto left = std::chrono::ceil<std::chrono::milliseconds>(until - Clock::now()).count();
      wait_ms = static_cast<int>(std::max<std::int64_t>(0, left));
    }
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, wait_ms);
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) {
      return make_error(ErrorCode::kIoError,
                        std::string("detector host: poll failed: ") + std::strerror(errno));
    }
    if (ready == 0) return Received{ReceiveOutcome::kTimeout, {}};
    // The packet's length first (MSG_PEEK | MSG_TRUNC), then the packet.
    const ssize_t size = ::recv(fd, nullptr, 0, MSG_PEEK | MSG_TRUNC);
    if (size < 0 && errno == EINTR) continue;
    if (size == 0 || (size < 0 && errno == ECONNRESET)) return Received{ReceiveOutcome::kClosed, {}};
    if (size < 0) {
      return make_error(ErrorCode::kIoError,
                        std::string("detector host: receive failed: ") + std::strerror(errno));
    }
    std::vector<std::uint8_t> buffer(std::min(static_cast<std::size_t>(size), kMaxMessageBytes));
    const ssize_t n = ::recv(fd, buffer.data(), buffer.size(), MSG_TRUNC);
    if (n < 0) {
      return make_error(ErrorCode::kIoError,
                        std::string("detector host: receive failed: ") + std::strerror(errno));
    }
    if (static_cast<std::size_t>(n) > kMaxMessageBytes) {
      return make_error(ErrorCode::kParseError, "detector host protocol: message of " + std::to_string(n) +
                                                    " bytes exceeds the limit");
    }
    buffer.resize(static_cast<std::size_t>(n));
    SITEPOSE_TRY(Envelope envelope, decode(buffer));
    return Received{ReceiveOutcome::kMessage, std::move(envelope)};
  }
}

}  // namespace sitepose::detector_host
