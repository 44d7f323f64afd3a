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
bool WriteAll(int fd, std::string_view content) {
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

// Writes what `write` hands its writer to a new temporary file beside `path` (mode 0644, in
// pieces of up to 64 KiB, flushed to disk) and returns its name. Throws OutputError, or what
// `write` throws; on failure nothing is left behind.
std::string WriteTemporary(const std::string& path,
                           const std::function<void(const ByteWriter&)>& write) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw OutputError(path + ": is a directory, cannot write a file");
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string tmpl = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) throw OutputError(path + ": cannot create a temporary file: " + Reason());
  constexpr std::size_t kBuffer = 1 << 16;
  std::string buffer;
  bool ok = ::fchmod(fd, 0644) == 0;  // mkstemp creates the file 0600; outputs are ordinary files
  std::string reason = ok ? "" : Reason();
  const auto flush = [&] {
    if (ok && !WriteAll(fd, buffer)) ok = false, reason = Reason();
    buffer.clear();
  };
  try {
    write([&](std::string_view bytes) {
      if (buffer.size() + bytes.size() > kBuffer) flush();
      if (bytes.size() >= kBuffer) {
        if (ok && !WriteAll(fd, bytes)) ok = false, reason = Reason();
      } else {
        buffer.append(bytes);
      }
    });
  } catch (...) {
    ::close(fd);
    ::unlink(tmpl.c_str());
    throw;
  }
  flush();
  if (ok && ::fsync(fd) != 0) ok = false, reason = Reason();
  const bool closed = ::close(fd) == 0;
  if (!ok || !closed) {
    if (ok) reason = Reason();
    ::unlink(tmpl.c_str());
    throw OutputError(path + ": write failed: " + reason);
  }
  return tmpl;
}

std::string WriteTemporary(const std::string& path, const std::string& content) {
  return WriteTemporary(path, [&](const ByteWriter& writer) { writer(content); });
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

std::string StagedFiles::Stage(const std::string& path,
                               const std::function<void(const ByteWriter&)>& write) {
  staged_.emplace_back(WriteTemporary(path, write), path);
  return staged_.back().first;
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
