#include "sitepose/drivers/v4l2/v4l2_io.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>

namespace sitepose::drivers::v4l2 {

namespace {

class SystemV4l2Io final : public V4l2Io {
 public:
  int open(const char* path, int flags) override { return ::open(path, flags); }
  int close(int fd) override { return ::close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override {
    int r;
    do {
      r = ::ioctl(fd, request, arg);
    } while (r == -1 && errno == EINTR);
    return r;
  }
  void* mmap(std::size_t length, int fd, off_t offset) override {
    return ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset);
  }
  int munmap(void* address, std::size_t length) override { return ::munmap(address, length); }
  int poll(struct pollfd* fds, nfds_t count, int timeout_ms) override {
    const int r = ::poll(fds, count, timeout_ms);
    return (r == -1 && errno == EINTR) ? 0 : r;
  }
};

}  // namespace

std::shared_ptr<V4l2Io> system_v4l2_io() { return std::make_shared<SystemV4l2Io>(); }

}  // namespace sitepose::drivers::v4l2
