// OpenLog / ReadAllScans (format detection) and the helpers shared by the readers.
#include "shape_slam_io/log_reader.h"

#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <limits>
#include <system_error>

#include "log_reader_internal.h"
#include "shape_slam_io/carmen_reader.h"
#ifdef SHAPE_SLAM_HAVE_MRPT
#include "shape_slam_io/rawlog_reader.h"
#endif

namespace shape_slam::io {
namespace internal {
namespace {

// zlib's own read buffer (the default is 8 KiB; larger is faster on big logs).
constexpr unsigned kZlibBufferBytes = 1u << 17;
// gzread takes an unsigned count and returns an int: read in chunks below INT_MAX.
constexpr std::size_t kMaxGzreadChunk = 1u << 30;

// zlib's message, without the "path: " zlib puts in front of it.
std::string ZlibErrorMessage(int code, const char* zlib_message, const std::string& path) {
  std::string detail = zlib_message != nullptr ? zlib_message : "";
  if (detail.rfind(path + ": ", 0) == 0) detail.erase(0, path.size() + 2);
  switch (code) {
    case Z_BUF_ERROR:
      return "truncated gzip data (zlib: " + detail + ")";
    case Z_DATA_ERROR:
      return "corrupt gzip data (zlib: " + detail + ")";
    case Z_ERRNO:
      return std::string("read error: ") + std::strerror(errno);
    case Z_MEM_ERROR:
      return "out of memory while decompressing";
    default:
      return "zlib error " + std::to_string(code) + ": " + detail;
  }
}

// True when the bytes start like an object written by mrpt::serialization::CArchive: one byte
// 0x80 | length followed by the class name (MRPT >= 0.5.5), or the length as a 32-bit
// little-endian integer below 0x80 followed by the class name (the older format MRPT still
// reads; its three zero bytes can never start a text file).
bool LooksLikeMrptObjectHeader(std::string_view head) {
  const auto first = static_cast<unsigned char>(head[0]);
  std::size_t begin = 1;
  const std::size_t length = first & 0x7F;
  if ((first & 0x80) == 0) {
    if (head.size() < 4 || head[1] != '\0' || head[2] != '\0' || head[3] != '\0') return false;
    begin = 4;
  }
  constexpr std::size_t kMaxClassNameLength = 120;  // as CArchive checks
  if (length == 0 || length > kMaxClassNameLength || head.size() < begin + length) return false;
  const std::string_view name = head.substr(begin, length);
  auto is_alpha = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); };
  auto is_name_char = [&](char c) {
    return is_alpha(c) || (c >= '0' && c <= '9') || c == '_' || c == ':';
  };
  if (!is_alpha(name[0])) return false;
  for (const char c : name) {
    if (!is_name_char(c)) return false;
  }
  return true;
}

// Bytes that do not belong in a text log: control characters other than white space, DEL,
// and bytes >= 0x80 (a few are fine: UTF-8 in a comment).
bool IsSuspiciousByte(unsigned char c) {
  const bool whitespace = c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
  return (c < 0x20 && !whitespace) || c >= 0x7F;
}

}  // namespace

void CheckLogPath(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string shown = path.empty() ? "(empty path)" : path;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (status.type() == fs::file_type::not_found) throw LogError(shown + ": no such file");
  if (ec) throw LogError(shown + ": cannot access: " + ec.message());
  if (fs::is_directory(status)) throw LogError(shown + ": is a directory, not a log file");
}

GzFile::GzFile(const std::string& path) : path_(path) {
  CheckLogPath(path);
  errno = 0;
  file_ = gzopen(path.c_str(), "rb");
  if (file_ == nullptr) {
    const std::string reason = errno != 0 ? std::strerror(errno) : "out of memory";
    throw LogError(path + ": cannot open: " + reason);
  }
  gzbuffer(file_, kZlibBufferBytes);
}

GzFile::~GzFile() { gzclose_r(file_); }

std::size_t GzFile::Read(char* data, std::size_t size) {
  if (!pending_error_.empty()) throw ZlibError(pending_error_);
  std::size_t total = 0;
  while (total < size) {
    const auto chunk = static_cast<unsigned>(std::min(size - total, kMaxGzreadChunk));
    const int n = gzread(file_, data + total, chunk);
    if (n > 0) total += static_cast<std::size_t>(n);
    // zlib reports a gzip stream that ends early as Z_BUF_ERROR ("unexpected end of file")
    // while still returning the bytes it could decode, then a plain 0 as at the end of the
    // file: the error code is the only trace of the truncation, so it is checked every time.
    int code = Z_OK;
    const char* message = gzerror(file_, &code);
    if (code != Z_OK) {
      pending_error_ = ZlibErrorMessage(code, message, path_);
      if (total == 0) throw ZlibError(pending_error_);
      return total;
    }
    if (n <= 0) break;
  }
  return total;
}

std::string ReadHead(const std::string& path, std::size_t max_bytes) {
  GzFile file(path);
  std::string head(max_bytes, '\0');
  try {
    head.resize(file.Read(head.data(), max_bytes));
    // A short head is the whole content: one more read surfaces a gzip error met at its end.
    char extra = 0;
    if (head.size() < max_bytes) file.Read(&extra, 1);
  } catch (const ZlibError& e) {
    throw LogError(path + ": " + e.what());
  }
  return head;
}

ContentKind ClassifyContent(std::string_view head) {
  head = head.substr(0, std::min(head.size(), kSniffBytes));
  if (head.empty()) return ContentKind::kEmpty;
  if (LooksLikeMrptObjectHeader(head)) return ContentKind::kMrptBinary;
  if (head.find('\0') != std::string_view::npos) return ContentKind::kBinary;
  std::size_t suspicious = 0;
  for (const char c : head) suspicious += IsSuspiciousByte(static_cast<unsigned char>(c)) ? 1 : 0;
  // Random bytes score about 60 %; text with a little UTF-8 stays far below 30 %.
  return 10 * suspicious > 3 * head.size() ? ContentKind::kBinary : ContentKind::kText;
}

void ReaderBookkeeping::Malformed(const std::string& where, const std::string& message) {
  if (strict_) throw LogError(where + ": " + message);
  ++stats_.skipped_records;
  Note(where, "skipped malformed record: " + message);
}

void ReaderBookkeeping::Note(const std::string& where, const std::string& message) {
  if (stats_.issues.size() < kMaxLogIssues) stats_.issues.push_back({where, message});
}

void ReaderBookkeeping::Delivered(const LaserScan& scan, const std::string& where) {
  ++stats_.scans;
  if (last_timestamp_s_ && scan.timestamp_s < *last_timestamp_s_) {
    ++stats_.non_monotonic_timestamps;
    Note(where, "timestamp " + FormatNumber(scan.timestamp_s) + " s is earlier than the previous " +
                    "scan's " + FormatNumber(*last_timestamp_s_) + " s");
  }
  last_timestamp_s_ = scan.timestamp_s;
}

std::string EmptyLogMessage(const std::string& path) {
  std::error_code ec;
  const bool empty_file = std::filesystem::file_size(path, ec) == 0 && !ec;
  return path + (empty_file ? ": empty file, not a log" : ": no data (empty gzip stream)");
}

std::string FormatNumber(double value) {
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

}  // namespace internal

namespace {

std::unique_ptr<LogReader> OpenRawlog(const std::string& path, const LogReaderOptions& options) {
#ifdef SHAPE_SLAM_HAVE_MRPT
  return std::make_unique<RawlogReader>(path, options);
#else
  (void)options;
  throw LogError(path +
                 ": is an MRPT rawlog, but ShapeSLAM was built without MRPT "
                 "(SHAPE_SLAM_WITH_MRPT=OFF)");
#endif
}

}  // namespace

std::unique_ptr<LogReader> OpenLog(const std::string& path, const LogReaderOptions& options) {
  const std::string head = internal::ReadHead(path, internal::kSniffBytes);
  switch (internal::ClassifyContent(head)) {
    case internal::ContentKind::kEmpty:
      throw LogError(internal::EmptyLogMessage(path));
    case internal::ContentKind::kText:
      return std::make_unique<CarmenReader>(path, options);
    case internal::ContentKind::kMrptBinary:
      return OpenRawlog(path, options);
    case internal::ContentKind::kBinary:
      break;
  }
  throw LogError(path +
                 ": unknown format: not a CARMEN log (binary content) and not an MRPT rawlog");
}

std::vector<LaserScan> ReadAllScans(const std::string& path, const LogReaderOptions& options) {
  const std::unique_ptr<LogReader> reader = OpenLog(path, options);
  std::vector<LaserScan> scans;
  while (std::optional<LaserScan> scan = reader->Next()) scans.push_back(std::move(*scan));
  return scans;
}

}  // namespace shape_slam::io
