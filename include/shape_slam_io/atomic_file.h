// Atomic output files: write to a temporary file beside the target, flush it to disk, then
// rename it over the target. A failed or interrupted run never leaves a half-written file and
// never destroys what was at the target before.
#pragma once

#include <stdexcept>
#include <string>

namespace shape_slam::io {

/// An output that could not be written; what() names the path and the reason.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Replaces `path` by `content` atomically (temporary file in the same directory + fsync +
/// rename). Throws OutputError; on failure the temporary file is removed and `path` untouched.
void WriteFileAtomically(const std::string& path, const std::string& content);

/// Creates `directory` (and its parents) unless it exists. Throws OutputError when it cannot,
/// or when the path exists and is not a directory.
void EnsureDirectory(const std::string& directory);

}  // namespace shape_slam::io
