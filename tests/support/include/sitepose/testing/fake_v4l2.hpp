#pragma once
// A fake V4L2 kernel behind the V4l2Io seam: capture devices by path that
// offer a list of pixel formats and sizes, hand out mmap buffers from
// memory, and fill them with frames the test pushes. A device can be
// unplugged (open fails with ENOENT, every call on an old descriptor with
// ENODEV, poll reports POLLERR | POLLHUP) and plugged back.
// Thread-safe: tests may push or unplug from another thread.

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sitepose/drivers/v4l2/v4l2_io.hpp"

namespace sitepose::drivers::v4l2::testing {

struct FakeDeviceSpec {
  std::vector<std::uint32_t> formats;  // fourccs in ENUM_FMT order
  std::vector<cv::Size> sizes;         // S_FMT keeps a listed size, else gives sizes[0]
  bool capture = true;                 // false: a metadata node
  bool monotonic_timestamps = true;
  double fps = 30.0;
};

struct FakeFrame {
  std::vector<std::uint8_t> bytes;
  std::int64_t t_ns = 0;
  bool error = false;  // V4L2_BUF_FLAG_ERROR
};

class FakeV4l2Io final : public V4l2Io {
 public:
  void add_device(const std::string& path, FakeDeviceSpec spec);
  // Fills a queued buffer of a streaming device; false (a dropped frame,
  // its sequence number skipped) when none is queued or it is not streaming.
  bool push(const std::string& path, FakeFrame frame);
  void unplug(const std::string& path);
  void plug(const std::string& path);
  bool streaming(const std::string& path);
  std::uint32_t format(const std::string& path);  // the fourcc set by S_FMT
  int open_descriptors();
  std::size_t mapped_buffers();
  int streamon_count(const std::string& path);

  int open(const char* path, int flags) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  void* mmap(std::size_t length, int fd, off_t offset) override;
  int munmap(void* address, std::size_t length) override;
  int poll(struct pollfd* fds, nfds_t count, int timeout_ms) override;

 private:
  struct Filled {
    std::uint32_t index;
    std::uint32_t bytes;
    std::int64_t t_ns;
    std::uint32_t sequence;
    bool error;
  };
  struct Device {
    FakeDeviceSpec spec;
    bool present = true;
    int generation = 0;
    std::uint32_t fourcc = 0;
    cv::Size size;
    std::uint32_t sizeimage = 0;
    std::uint32_t numerator = 1000, denominator = 30000;
    std::vector<std::shared_ptr<std::vector<std::uint8_t>>> buffers;
    std::vector<std::uint32_t> queued;
    std::vector<Filled> filled;
    bool streaming = false;
    std::uint32_t sequence = 0;
    int streamons = 0;
  };
  struct Handle {
    std::string path;
    int generation;
  };
  // Device of a live descriptor, or nullptr with errno set (EBADF, ENODEV).
  Device* device_of(int fd);
  int format_ioctl(Device& d, unsigned long request, void* arg);
  int buffer_ioctl(Device& d, unsigned long request, void* arg);

  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, Device> devices_;
  std::map<int, Handle> handles_;
  std::map<void*, std::shared_ptr<std::vector<std::uint8_t>>> mappings_;
  int next_fd_ = 100;
};

// Frame bytes of a gray image in a format (GREY raw, YUYV with U = V = 128,
// MJPEG as a JPEG of quality 95).
std::vector<std::uint8_t> encode_frame(const cv::Mat& gray, std::uint32_t fourcc);

// Writes, at `path`, the calibration of an ideal pair seeing `image_size`
// (one camera's image): focal 70 px, principal point at the centre, no
// distortion, parallel, 0.1 m baseline — rectification is the identity, so a
// fake frame comes out of a source as it went in. False when it cannot be
// written.
bool write_ideal_calibration(const std::string& path, cv::Size image_size);

}  // namespace sitepose::drivers::v4l2::testing
