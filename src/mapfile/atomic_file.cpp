#include "sitepose/mapfile/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

namespace sitepose::mapfile {
namespace {

std::string errno_text() { return std::strerror(errno); }

Unexpected io_error(const std::string& what, const std::filesystem::path& path) {
  return make_error(ErrorCode::kIoError, what + " " + path.string() + ": " + errno_text());
}

Status write_all(int fd, std::span<const std::uint8_t> bytes, const std::filesystem::path& path) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return io_error("cannot write", path);
    done += static_cast<std::size_t>(n);
  }
  return ok_status();
}

// Temp files of writers that died mid-save ("<name>.tmp-<pid>" of a pid
// that no longer runs); a live writer's temp file is left alone.
void remove_stale_temps(const std::filesystem::path& target) {
  const std::string prefix = target.filename().string() + ".tmp-";
  std::error_code ec;
  const std::filesystem::path folder = target.has_parent_path() ? target.parent_path() : ".";
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string pid_text = name.substr(prefix.size());
    if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(pid_text));
    if (::kill(pid, 0) != 0 && errno == ESRCH) std::filesystem::remove(entry.path(), ec);
  }
}

Status fsync_folder(const std::filesystem::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return io_error("cannot open folder", folder);
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return io_error("cannot fsync folder", folder);
  return ok_status();
}

}  // namespace

Status write_file_atomically(const std::filesystem::path& target, std::span<const std::uint8_t> bytes) {
  remove_stale_temps(target);
  const std::filesystem::path temp = target.string() + ".tmp-" + std::to_string(::getpid());
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return io_error("cannot create", temp);
  Status written = write_all(fd, bytes, temp);
  if (written && ::fsync(fd) != 0) written = io_error("cannot fsync", temp);
  if (::close(fd) != 0 && written) written = io_error("cannot close", temp);
  if (written && ::rename(temp.c_str(), target.c_str()) != 0)
    written = io_error("cannot rename onto", target);
  if (!written) {
    std::error_code ec;
    std::filesystem::remove(temp, ec);
    return written;
  }
  return fsync_folder(target.has_parent_path() ? target.parent_path() : ".");
}

}  // namespace sitepose::mapfile
