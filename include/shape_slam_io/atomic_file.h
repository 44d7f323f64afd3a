// Atomic output files: write to a temporary file beside the target, flush it to disk, then
// rename it over the target. A failed or interrupted run never leaves a half-written file and
// never destroys what was at the target before.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace shape_slam::io {

/// An output that could not be written; what() names the path and the reason.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Replaces `path` by `content` atomically (temporary file in the same directory + fsync +
/// rename). Throws OutputError; on failure the temporary file is removed and `path` untouched.
void WriteFileAtomically(const std::string& path, const std::string& content);

/// Takes the next piece of an output's content (StagedFiles::Stage with a writer).
using ByteWriter = std::function<void(std::string_view bytes)>;

/// Files replaced together, without holding their contents in memory: Stage writes a file's
/// content to a temporary file beside its target (flushed to disk, as WriteFileAtomically);
/// Commit renames every staged file over its target, in the order staged. Temporary files not
/// committed are removed when the object goes away: a failure before Commit leaves every target
/// as it was. Throws OutputError.
class StagedFiles {
 public:
  StagedFiles() = default;
  StagedFiles(const StagedFiles&) = delete;
  StagedFiles& operator=(const StagedFiles&) = delete;
  ~StagedFiles();

  void Stage(const std::string& path, const std::string& content);
  /// As Stage(path, content), the content handed piece by piece by `write` to the writer it is
  /// given (buffered), so that a large output need never be held whole. An exception from
  /// `write` removes the temporary file and propagates. Returns the temporary file's path: it
  /// can be read back until Commit.
  std::string Stage(const std::string& path, const std::function<void(const ByteWriter&)>& write);
  void Commit();

 private:
  std::vector<std::pair<std::string, std::string>> staged_;  // temporary file, target
};

/// Creates `directory` (and its parents) unless it exists. Throws OutputError when it cannot,
/// or when the path exists and is not a directory.
void EnsureDirectory(const std::string& directory);

}  // namespace shape_slam::io
