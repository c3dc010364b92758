#include "sitepose/testing/fake_v4l2.hpp"

#include <linux/videodev2.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "sitepose/calib/calibration_file.hpp"

namespace sitepose::drivers::v4l2::testing {

namespace {
constexpr std::uint32_t kOffsetStride = 0x1000000;
}

void FakeV4l2Io::add_device(const std::string& path, FakeDeviceSpec spec) {
  std::lock_guard lock(mutex_);
  Device& d = devices_[path];
  d.spec = std::move(spec);
  d.denominator = static_cast<std::uint32_t>(d.spec.fps * 1000.0);
}

bool FakeV4l2Io::push(const std::string& path, FakeFrame frame) {
  std::lock_guard lock(mutex_);
  Device& d = devices_.at(path);
  const std::uint32_t sequence = d.sequence++;
  if (!d.present || !d.streaming || d.queued.empty()) return false;
  const std::uint32_t index = d.queued.front();
  d.queued.erase(d.queued.begin());
  auto& buffer = *d.buffers[index];
  const std::size_t n = std::min(buffer.size(), frame.bytes.size());
  std::copy(frame.bytes.begin(), frame.bytes.begin() + static_cast<std::ptrdiff_t>(n), buffer.begin());
  d.filled.push_back({index, static_cast<std::uint32_t>(n), frame.t_ns, sequence, frame.error});
  changed_.notify_all();
  return true;
}

void FakeV4l2Io::unplug(const std::string& path) {
  std::lock_guard lock(mutex_);
  Device& d = devices_.at(path);
  d.present = false;
  ++d.generation;
  d.streaming = false;
  d.queued.clear();
  d.filled.clear();
  d.buffers.clear();  // mappings keep their memory until munmap, as in the kernel
  changed_.notify_all();
}

void FakeV4l2Io::plug(const std::string& path) {
  std::lock_guard lock(mutex_);
  devices_.at(path).present = true;
}

bool FakeV4l2Io::streaming(const std::string& path) {
  std::lock_guard lock(mutex_);
  return devices_.at(path).streaming;
}

std::uint32_t FakeV4l2Io::format(const std::string& path) {
  std::lock_guard lock(mutex_);
  return devices_.at(path).fourcc;
}

int FakeV4l2Io::open_descriptors() {
  std::lock_guard lock(mutex_);
  return static_cast<int>(handles_.size());
}

std::size_t FakeV4l2Io::mapped_buffers() {
  std::lock_guard lock(mutex_);
  return mappings_.size();
}

int FakeV4l2Io::streamon_count(const std::string& path) {
  std::lock_guard lock(mutex_);
  return devices_.at(path).streamons;
}

int FakeV4l2Io::open(const char* path, int /*flags*/) {
  std::lock_guard lock(mutex_);
  auto it = devices_.find(path);
  if (it == devices_.end() || !it->second.present) {
    errno = ENOENT;
    return -1;
  }
  const int fd = next_fd_++;
  handles_[fd] = {path, it->second.generation};
  return fd;
}

int FakeV4l2Io::close(int fd) {
  std::lock_guard lock(mutex_);
  auto it = handles_.find(fd);
  if (it == handles_.end()) {
    errno = EBADF;
    return -1;
  }
  auto d = devices_.find(it->second.path);
  if (d != devices_.end() && d->second.generation == it->second.generation) {
    d->second.streaming = false;  // the last close releases the buffers
    d->second.buffers.clear();
    d->second.queued.clear();
    d->second.filled.clear();
  }
  handles_.erase(it);
  return 0;
}

FakeV4l2Io::Device* FakeV4l2Io::device_of(int fd) {
  auto it = handles_.find(fd);
  if (it == handles_.end()) {
    errno = EBADF;
    return nullptr;
  }
  Device& d = devices_.at(it->second.path);
  if (!d.present || d.generation != it->second.generation) {
    errno = ENODEV;
    return nullptr;
  }
  return &d;
}

int FakeV4l2Io::ioctl(int fd, unsigned long request, void* arg) {
  std::lock_guard lock(mutex_);
  Device* d = device_of(fd);
  if (d == nullptr) return -1;
  if (request == VIDIOC_QUERYCAP) {
    auto* cap = static_cast<v4l2_capability*>(arg);
    *cap = {};
    std::strcpy(reinterpret_cast<char*>(cap->driver), "fake");
    cap->device_caps =
        d->spec.capture ? (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING) : V4L2_CAP_META_CAPTURE;
    cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS;
    return 0;
  }
  if (request == VIDIOC_ENUM_FMT || request == VIDIOC_S_FMT || request == VIDIOC_S_PARM ||
      request == VIDIOC_G_PARM) {
    return format_ioctl(*d, request, arg);
  }
  return buffer_ioctl(*d, request, arg);
}

int FakeV4l2Io::format_ioctl(Device& d, unsigned long request, void* arg) {
  if (request == VIDIOC_ENUM_FMT) {
    auto* desc = static_cast<v4l2_fmtdesc*>(arg);
    if (desc->index >= d.spec.formats.size()) {
      errno = EINVAL;
      return -1;
    }
    desc->pixelformat = d.spec.formats[desc->index];
    return 0;
  }
  if (request == VIDIOC_S_FMT) {
    auto& pix = static_cast<v4l2_format*>(arg)->fmt.pix;
    if (std::find(d.spec.formats.begin(), d.spec.formats.end(), pix.pixelformat) == d.spec.formats.end()) {
      pix.pixelformat = d.spec.formats.front();  // drivers adjust, they do not refuse
    }
    const cv::Size want(static_cast<int>(pix.width), static_cast<int>(pix.height));
    const bool listed = std::find(d.spec.sizes.begin(), d.spec.sizes.end(), want) != d.spec.sizes.end();
    d.size = listed ? want : d.spec.sizes.front();
    d.fourcc = pix.pixelformat;
    pix.width = static_cast<std::uint32_t>(d.size.width);
    pix.height = static_cast<std::uint32_t>(d.size.height);
    const auto w = static_cast<std::uint32_t>(d.size.width), h = static_cast<std::uint32_t>(d.size.height);
    pix.bytesperline = d.fourcc == V4L2_PIX_FMT_YUYV ? 2 * w : (d.fourcc == V4L2_PIX_FMT_GREY ? w : 0);
    d.sizeimage = pix.sizeimage = (d.fourcc == V4L2_PIX_FMT_GREY ? 1 : 2) * w * h;
    return 0;
  }
  auto* parm = static_cast<v4l2_streamparm*>(arg);
  if (request == VIDIOC_S_PARM) {
    d.numerator = parm->parm.capture.timeperframe.numerator;
    d.denominator = parm->parm.capture.timeperframe.denominator;
  }
  parm->parm.capture.timeperframe.numerator = d.numerator;
  parm->parm.capture.timeperframe.denominator = d.denominator;
  return 0;
}

int FakeV4l2Io::buffer_ioctl(Device& d, unsigned long request, void* arg) {
  if (request == VIDIOC_REQBUFS) {
    auto* req = static_cast<v4l2_requestbuffers*>(arg);
    req->count = std::min<std::uint32_t>(req->count, 8);
    d.buffers.clear();
    for (std::uint32_t i = 0; i < req->count; ++i) {
      d.buffers.push_back(std::make_shared<std::vector<std::uint8_t>>(d.sizeimage));
    }
    return 0;
  }
  auto* buf = static_cast<v4l2_buffer*>(arg);
  if (request == VIDIOC_QUERYBUF || request == VIDIOC_QBUF) {
    if (buf->index >= d.buffers.size()) {
      errno = EINVAL;
      return -1;
    }
    buf->length = static_cast<std::uint32_t>(d.buffers[buf->index]->size());
    buf->m.offset = buf->index * kOffsetStride;
    if (request == VIDIOC_QBUF) d.queued.push_back(buf->index);
    return 0;
  }
  if (request == VIDIOC_DQBUF) {
    if (!d.streaming) {
      errno = EINVAL;
      return -1;
    }
    if (d.filled.empty()) {
      errno = EAGAIN;
      return -1;
    }
    const Filled f = d.filled.front();
    d.filled.erase(d.filled.begin());
    buf->index = f.index;
    buf->bytesused = f.bytes;
    buf->sequence = f.sequence;
    buf->flags =
        (d.spec.monotonic_timestamps ? V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC : V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN) |
        (f.error ? V4L2_BUF_FLAG_ERROR : 0);
    buf->timestamp.tv_sec = f.t_ns / 1'000'000'000;
    buf->timestamp.tv_usec = (f.t_ns % 1'000'000'000) / 1000;
    return 0;
  }
  if (request == VIDIOC_STREAMON || request == VIDIOC_STREAMOFF) {
    d.streaming = request == VIDIOC_STREAMON;
    if (d.streaming) ++d.streamons;
    return 0;
  }
  errno = ENOTTY;
  return -1;
}

void* FakeV4l2Io::mmap(std::size_t length, int fd, off_t offset) {
  std::lock_guard lock(mutex_);
  Device* d = device_of(fd);
  if (d == nullptr) return MAP_FAILED;
  const auto index = static_cast<std::size_t>(offset) / kOffsetStride;
  if (index >= d->buffers.size() || length > d->buffers[index]->size()) {
    errno = EINVAL;
    return MAP_FAILED;
  }
  void* address = d->buffers[index]->data();
  mappings_[address] = d->buffers[index];
  return address;
}

int FakeV4l2Io::munmap(void* address, std::size_t /*length*/) {
  std::lock_guard lock(mutex_);
  if (mappings_.erase(address) == 0) {
    errno = EINVAL;
    return -1;
  }
  return 0;
}

int FakeV4l2Io::poll(struct pollfd* fds, nfds_t count, int timeout_ms) {
  std::unique_lock lock(mutex_);
  auto ready = [&] {
    int n = 0;
    for (nfds_t i = 0; i < count; ++i) {
      fds[i].revents = 0;
      auto h = handles_.find(fds[i].fd);
      if (h == handles_.end()) {
        fds[i].revents = POLLNVAL;
      } else {
        const Device& d = devices_.at(h->second.path);
        if (!d.present || d.generation != h->second.generation) {
          fds[i].revents = POLLERR | POLLHUP;
        } else if (!d.filled.empty()) {
          fds[i].revents = POLLIN | POLLRDNORM;
        }
      }
      if (fds[i].revents != 0) ++n;
    }
    return n;
  };
  int n = 0;
  changed_.wait_for(lock, std::chrono::milliseconds(std::max(timeout_ms, 0)),
                    [&] { return (n = ready()) > 0; });
  return n;
}

std::vector<std::uint8_t> encode_frame(const cv::Mat& gray, std::uint32_t fourcc) {
  std::vector<std::uint8_t> bytes;
  if (fourcc == V4L2_PIX_FMT_MJPEG) {
    cv::imencode(".jpg", gray, bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
    return bytes;
  }
  const bool yuyv = fourcc == V4L2_PIX_FMT_YUYV;
  bytes.reserve(gray.total() * (yuyv ? 2 : 1));
  for (int y = 0; y < gray.rows; ++y) {
    for (int x = 0; x < gray.cols; ++x) {
      bytes.push_back(gray.at<std::uint8_t>(y, x));
      if (yuyv) bytes.push_back(128);
    }
  }
  return bytes;
}

bool write_ideal_calibration(const std::string& path, cv::Size image_size) {
  calib::StereoCalibration c;
  c.image_size = image_size;
  const double cx = (image_size.width - 1) / 2.0;
  const double cy = (image_size.height - 1) / 2.0;
  c.K1 = (cv::Mat_<double>(3, 3) << 70, 0, cx, 0, 70, cy, 0, 0, 1);
  c.K2 = c.K1.clone();
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
  return calib::compute_rectification(c).has_value() && calib::write_stereo_calibration(path, c).has_value();
}

}  // namespace sitepose::drivers::v4l2::testing
