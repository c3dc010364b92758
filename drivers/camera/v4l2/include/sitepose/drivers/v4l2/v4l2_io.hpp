#pragma once
// The seam between the V4L2 driver and the kernel: every open, close, ioctl,
// mmap, munmap and poll the driver makes goes through a V4l2Io, so the
// driver's logic (format negotiation, buffer handling, pairing, reconnect)
// is tested against a fake device (tests/unit/drivers/v4l2); CI has no
// /dev/video*.
// Each call behaves like the system call: -1 (MAP_FAILED for mmap) and errno
// set on failure. Implementations must be safe to call from the thread that
// owns the camera; the driver never shares a descriptor between threads.

#include <poll.h>
#include <sys/types.h>

#include <cstddef>
#include <memory>

namespace sitepose::drivers::v4l2 {

class V4l2Io {
 public:
  virtual ~V4l2Io() = default;
  virtual int open(const char* path, int flags) = 0;
  virtual int close(int fd) = 0;
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;
  // PROT_READ | PROT_WRITE, MAP_SHARED at `offset` (from VIDIOC_QUERYBUF).
  virtual void* mmap(std::size_t length, int fd, off_t offset) = 0;
  virtual int munmap(void* address, std::size_t length) = 0;
  virtual int poll(struct pollfd* fds, nfds_t count, int timeout_ms) = 0;
};

// The real calls (ioctl retried on EINTR).
std::shared_ptr<V4l2Io> system_v4l2_io();

}  // namespace sitepose::drivers::v4l2
