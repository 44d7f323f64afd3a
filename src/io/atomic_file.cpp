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

// Writes `content` to a new temporary file beside `path` (mode 0644, flushed to disk) and
// returns its name. Throws OutputError; on failure nothing is left behind.
std::string WriteTemporary(const std::string& path, const std::string& content) {
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
  return tmpl;
}

// Renames the temporary file over `path`; on failure removes it and throws OutputError.
void ReplaceWith(const std::string& temporary, const std::string& path) {
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string reason = Reason();
    ::unlink(temporary.c_str());
    throw OutputError(path + ": cannot replace the file: " + reason);
  }
}

}  // namespace

void WriteFileAtomically(const std::string& path, const std::string& content) {
  ReplaceWith(WriteTemporary(path, content), path);
}

StagedFiles::~StagedFiles() {
  for (const auto& [temporary, path] : staged_) ::unlink(temporary.c_str());
}

void StagedFiles::Stage(const std::string& path, const std::string& content) {
  staged_.emplace_back(WriteTemporary(path, content), path);
}

void StagedFiles::Commit() {
  while (!staged_.empty()) {
    const auto [temporary, path] = staged_.front();
    staged_.erase(staged_.begin());
    ReplaceWith(temporary, path);
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
