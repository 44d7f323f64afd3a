// Private helpers shared by the log readers (never installed): reading a file through zlib with
// every zlib error surfaced, content sniffing for the format detection, and the bookkeeping of
// LogReaderStats (issues, skipped records, timestamp order).
#pragma once

#include <zlib.h>

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "shape_slam_io/log_reader.h"

namespace shape_slam::io::internal {

/// A zlib failure while reading (corrupt or truncated gzip data, read error). what() does not
/// name the file: the reader adds the file and the line or entry.
class ZlibError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws LogError when `path` does not exist, is a directory or cannot be inspected.
void CheckLogPath(const std::string& path);

/// Sequential reader of a file through zlib: gzip (one or several members) or plain bytes.
/// Unlike a bare gzread loop it never mistakes a truncated gzip stream for the end of the data:
/// zlib's "unexpected end of file" (Z_BUF_ERROR) and every other error become ZlibError.
class GzFile {
 public:
  /// Throws LogError for a missing path, a directory or a file that cannot be opened.
  explicit GzFile(const std::string& path);
  ~GzFile();
  GzFile(const GzFile&) = delete;
  GzFile& operator=(const GzFile&) = delete;

  /// Reads up to `size` bytes into `data`; returns how many. Returns 0 only at the true end of
  /// the data. Throws ZlibError on corrupt or truncated data; the bytes decoded before the
  /// failure are returned first and the following call throws.
  std::size_t Read(char* data, std::size_t size);

 private:
  std::string path_;
  gzFile file_ = nullptr;
  std::string pending_error_;
};

/// The first `max_bytes` bytes of the file's content (decompressed when gzip). Throws LogError
/// (path problems, or corrupt gzip data at the start of the file, naming the file).
std::string ReadHead(const std::string& path, std::size_t max_bytes);

/// "path: empty file, not a log" or "path: no data (empty gzip stream)".
std::string EmptyLogMessage(const std::string& path);

/// What the first bytes of a (decompressed) file look like.
enum class ContentKind {
  kEmpty,       ///< no byte at all
  kText,        ///< printable text: a CARMEN log candidate
  kMrptBinary,  ///< starts with an MRPT serialized object header (class name)
  kBinary,      ///< NUL bytes or mostly non-printable, and not MRPT
};

/// How many bytes of the content ClassifyContent looks at.
inline constexpr std::size_t kSniffBytes = 1024;

/// Sniffs the kind of content from its first bytes (up to kSniffBytes are used).
ContentKind ClassifyContent(std::string_view head);

/// The counters and issues of one reader, with the strict/non-strict policy.
class ReaderBookkeeping {
 public:
  explicit ReaderBookkeeping(bool strict) : strict_(strict) {}

  /// A malformed record at `where`: throws LogError("where: message") when strict; otherwise
  /// counts it as skipped and records the issue.
  void Malformed(const std::string& where, const std::string& message);
  /// Records an issue that is not an error (counters unchanged).
  void Note(const std::string& where, const std::string& message);
  /// Counts readings turned into NaN.
  void AddInvalidRanges(std::size_t count) { stats_.invalid_ranges += count; }
  /// Counts a delivered scan and checks that timestamps do not go backwards.
  void Delivered(const LaserScan& scan, const std::string& where);

  bool strict() const { return strict_; }
  const LogReaderStats& stats() const { return stats_; }

 private:
  bool strict_;
  LogReaderStats stats_;
  std::optional<double> last_timestamp_s_;
};

/// Prints a number for a message (shortest form that round-trips).
std::string FormatNumber(double value);

}  // namespace shape_slam::io::internal
