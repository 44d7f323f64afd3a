#include "shape_slam_io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace shape_slam::io {
namespace {

std::string Reason() { return std::strerror(errno); }

// Writes all of `content` to `fd`, retrying on short writes and EINTR.
bool WriteAll(int fd, const std::string& content) {
  const char* data = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    left -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

void WriteFileAtomically(const std::string& path, const std::string& content) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw OutputError(path + ": is a directory, cannot write a file");
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string tmpl = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) throw OutputError(path + ": cannot create a temporary file: " + Reason());
  // mkstemp creates the file 0600; outputs are ordinary files readable by others.
  const bool ok = ::fchmod(fd, 0644) == 0 && WriteAll(fd, content) && ::fsync(fd) == 0;
  const std::string write_reason = ok ? "" : Reason();
  const bool closed = ::close(fd) == 0;
  if (!ok || !closed) {
    ::unlink(tmpl.c_str());
    throw OutputError(path + ": write failed: " + (ok ? Reason() : write_reason));
  }
  if (::rename(tmpl.c_str(), path.c_str()) != 0) {
    const std::string reason = Reason();
    ::unlink(tmpl.c_str());
    throw OutputError(path + ": cannot replace the file: " + reason);
  }
}

void EnsureDirectory(const std::string& directory) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(directory, ec)) {
    if (!fs::is_directory(directory, ec)) {
      throw OutputError(directory + ": exists and is not a directory");
    }
    return;
  }
  fs::create_directories(directory, ec);
  if (ec) throw OutputError(directory + ": cannot create the directory: " + ec.message());
}

}  // namespace shape_slam::io
