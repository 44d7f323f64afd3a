// MRPT rawlogs (built only with MRPT): entries deserialized one by one with CArchive, paired
// like CRawlog::getActionObservationPairOrObservation, converted to LaserScan.
//
// getActionObservationPairOrObservation itself is not used: it catches every exception, prints
// it to std::cerr and returns false, so a truncated or corrupt rawlog cannot be told from its
// end. The same loop is written here over a stream that knows where the data really ends.
#include "shape_slam_io/rawlog_reader.h"

#include <mrpt/core/Clock.h>
#include <mrpt/io/CStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "log_reader_internal.h"
#include "shape_slam_io/mrpt_scan.h"

namespace shape_slam::io {
namespace {

constexpr std::size_t kStreamChunkBytes = 1 << 18;

/// A malformed scan or odometry; what() says what is wrong (the caller adds the entry).
class RecordError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A read-only mrpt::io::CStream over internal::GzFile that can tell the true end of the data
/// (AtEnd) from a stream that stops inside an entry (short_read, error).
class GzInputStream final : public mrpt::io::CStream {
 public:
  explicit GzInputStream(const std::string& path)
      : path_(path), file_(path), buffer_(kStreamChunkBytes) {}

  size_t Read(void* data, size_t count) override {
    auto* out = static_cast<char*>(data);
    std::size_t copied = 0;
    while (copied < count && (begin_ < end_ || Fill())) {
      const std::size_t n = std::min(count - copied, end_ - begin_);
      std::copy_n(buffer_.data() + begin_, n, out + copied);
      begin_ += n;
      copied += n;
    }
    position_ += copied;
    if (copied < count) short_read_ = true;
    return copied;
  }
  size_t Write(const void* /*data*/, size_t /*count*/) override {
    throw std::logic_error(path_ + ": the rawlog stream is read-only");
  }
  uint64_t Seek(int64_t /*offset*/, TSeekOrigin /*origin*/) override {
    throw std::logic_error(path_ + ": the rawlog stream is not seekable");
  }
  // The size of decompressed data is unknown before its end: the bytes known so far.
  uint64_t getTotalBytesCount() const override { return position_ + (end_ - begin_); }
  uint64_t getPosition() const override { return position_; }
  std::string getStreamDescription() const override { return path_; }

  /// True when no byte is left. False when bytes are left or a zlib error stopped the data
  /// (error() then says why, and the next read comes up short).
  bool AtEnd() { return begin_ == end_ && !Fill() && error_.empty(); }
  /// The zlib error met so far, or empty.
  const std::string& error() const { return error_; }
  /// Whether a read came up short since the last ClearShortRead().
  bool short_read() const { return short_read_; }
  void ClearShortRead() { short_read_ = false; }

 private:
  bool Fill() {
    if (!error_.empty()) return false;
    std::size_t n = 0;
    try {
      n = file_.Read(buffer_.data(), buffer_.size());
    } catch (const internal::ZlibError& e) {
      error_ = e.what();
    }
    begin_ = 0;
    end_ = n;
    return n > 0;
  }

  std::string path_;
  internal::GzFile file_;
  std::vector<char> buffer_;
  std::size_t begin_ = 0;
  std::size_t end_ = 0;
  uint64_t position_ = 0;
  std::string error_;
  bool short_read_ = false;
};

/// MRPT exceptions carry nested "Message:" lines and call stacks: keeps the messages only.
std::string CompactMrptMessage(const std::string& what) {
  std::istringstream lines(what);
  std::string line;
  std::string compact;
  while (std::getline(lines, line)) {
    const std::string::size_type at = line.find("Message:");
    if (at == std::string::npos) continue;
    const std::string::size_type text = line.find_first_not_of(' ', at + 8);
    if (text == std::string::npos) continue;
    compact += (compact.empty() ? "" : " > ") + line.substr(text);
  }
  if (!compact.empty()) return compact;
  return what.substr(0, what.find('\n'));
}

bool IsFinite(const mrpt::poses::CPose2D& pose) {
  return std::isfinite(pose.x()) && std::isfinite(pose.y()) && std::isfinite(pose.phi());
}

/// The rawlog's rule on top of the shared conversion (mrpt_scan.h): a scan needs a timestamp.
ConvertedMrptScan ToLaserScan(const mrpt::obs::CObservation2DRangeScan& obs) {
  if (obs.timestamp == mrpt::Clock::time_point()) throw RecordError("laser scan with no timestamp");
  try {
    return FromMrptScan(obs);
  } catch (const std::invalid_argument& e) {
    throw RecordError(e.what());
  }
}

Pose2 ToPose2(const mrpt::poses::CPose2D& pose) {
  return {pose.x(), pose.y(), NormalizeAngle(pose.phi())};
}

}  // namespace

struct RawlogReader::Impl {
  struct PendingScan {
    LaserScan scan;
    std::size_t invalid_ranges = 0;
    std::size_t entry = 0;
  };

  Impl(const std::string& path_in, bool strict)
      : path(path_in), stream(path_in), archive(stream), bookkeeping(strict) {}

  std::string Where(std::size_t index) const { return path + ": entry " + std::to_string(index); }
  void ReadNextEntry();
  void FailAt(std::size_t index, const std::string& message);
  void Dispatch(const mrpt::serialization::CSerializable::Ptr& object, std::size_t index);
  void ApplyActions(const mrpt::obs::CActionCollection& actions, std::size_t index);
  void TakeFrame(const mrpt::obs::CSensoryFrame& frame, std::size_t index);
  void HandleObservation(const mrpt::obs::CObservation& observation, std::size_t index);
  std::string NoScanMessage() const;

  std::string path;
  GzInputStream stream;
  mrpt::serialization::CArchiveStreamBase<GzInputStream> archive;
  internal::ReaderBookkeeping bookkeeping;
  std::deque<PendingScan> pending;    // scans read, not yet delivered
  std::size_t next_entry = 0;         // index of the next top-level entry
  std::optional<Pose2> T_odom_robot;  // odometry so far (increments or absolute)
  bool finished = false;
};

void RawlogReader::Impl::ReadNextEntry() {
  if (stream.AtEnd()) {
    finished = true;
    return;
  }
  const std::size_t index = next_entry++;
  mrpt::serialization::CSerializable::Ptr object;
  stream.ClearShortRead();
  try {
    object = archive.ReadObject();
  } catch (const std::exception& e) {
    FailAt(index, stream.error().empty() ? CompactMrptMessage(e.what()) : stream.error());
    return;
  }
  // MRPT does not check the length of every read: a stream that stopped inside the entry may
  // still have produced an object, made of garbage.
  if (stream.short_read()) {
    FailAt(index, stream.error().empty() ? "the data ends inside the entry" : stream.error());
    return;
  }
  Dispatch(object, index);
}

// A truncated or corrupt entry: nothing after it can be read.
void RawlogReader::Impl::FailAt(std::size_t index, const std::string& message) {
  const std::string what = "truncated or corrupt rawlog: " + message;
  if (bookkeeping.strict() || bookkeeping.stats().scans == 0) {
    throw LogError(Where(index) + ": " + what);
  }
  bookkeeping.Malformed(Where(index), what + "; the log ends here");
  finished = true;
}

void RawlogReader::Impl::Dispatch(const mrpt::serialization::CSerializable::Ptr& object,
                                  std::size_t index) {
  if (const auto actions = std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(object)) {
    ApplyActions(*actions, index);
  } else if (const auto frame = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(object)) {
    TakeFrame(*frame, index);
  } else if (const auto observation = std::dynamic_pointer_cast<mrpt::obs::CObservation>(object)) {
    HandleObservation(*observation, index);
  }
}

void RawlogReader::Impl::ApplyActions(const mrpt::obs::CActionCollection& actions,
                                      std::size_t index) {
  const mrpt::obs::CActionRobotMovement2D::Ptr movement = actions.getBestMovementEstimation();
  if (!movement || !movement->poseChange) return;
  const mrpt::poses::CPose2D increment = movement->poseChange->getMeanVal();
  if (!IsFinite(increment)) {
    bookkeeping.Malformed(Where(index), "odometry increment is not finite");
    return;
  }
  T_odom_robot = T_odom_robot.value_or(Pose2()) * ToPose2(increment);
}

// Every frame is used. MRPT pairs each frame with the odometry action before it (and its
// CRawlog reader drops a frame without one, such as the first of MRPT's sample log); such a frame
// gets no odometry increment: the odometry so far, the origin before the first action.
void RawlogReader::Impl::TakeFrame(const mrpt::obs::CSensoryFrame& frame, std::size_t index) {
  if (!T_odom_robot) T_odom_robot = Pose2();
  for (const mrpt::obs::CObservation::Ptr& observation : frame) {
    if (observation) HandleObservation(*observation, index);
  }
}

void RawlogReader::Impl::HandleObservation(const mrpt::obs::CObservation& observation,
                                           std::size_t index) {
  if (const auto* odometry = dynamic_cast<const mrpt::obs::CObservationOdometry*>(&observation)) {
    if (IsFinite(odometry->odometry)) {
      T_odom_robot = ToPose2(odometry->odometry);
    } else {
      bookkeeping.Malformed(Where(index), "odometry pose is not finite");
    }
    return;
  }
  const auto* obs = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&observation);
  if (obs == nullptr) return;
  try {
    ConvertedMrptScan converted = ToLaserScan(*obs);
    converted.scan.T_odom_robot = T_odom_robot;
    pending.push_back({std::move(converted.scan), converted.invalid_ranges, index});
  } catch (const RecordError& e) {
    bookkeeping.Malformed(Where(index), e.what());
  }
}

std::string RawlogReader::Impl::NoScanMessage() const {
  std::string message = path + ": no laser scans (CObservation2DRangeScan) found in " +
                        std::to_string(next_entry) + " entries";
  if (bookkeeping.stats().skipped_records > 0) {
    message += "; " + std::to_string(bookkeeping.stats().skipped_records) + " malformed records";
  }
  return message;
}

RawlogReader::RawlogReader(const std::string& path, const LogReaderOptions& options) : path_(path) {
  const std::string head = internal::ReadHead(path_, internal::kSniffBytes);
  const internal::ContentKind kind = internal::ClassifyContent(head);
  if (kind == internal::ContentKind::kEmpty) throw LogError(internal::EmptyLogMessage(path_));
  if (kind != internal::ContentKind::kMrptBinary) {
    throw LogError(path_ + ": not an MRPT rawlog (no serialized MRPT object at the start)");
  }
  impl_ = std::make_unique<Impl>(path_, options.strict);
  while (impl_->pending.empty() && !impl_->finished) impl_->ReadNextEntry();
  if (impl_->pending.empty()) throw LogError(impl_->NoScanMessage());
}

RawlogReader::~RawlogReader() = default;

std::optional<LaserScan> RawlogReader::Next() {
  Impl& impl = *impl_;
  while (impl.pending.empty()) {
    if (impl.finished) return std::nullopt;
    impl.ReadNextEntry();
  }
  Impl::PendingScan next = std::move(impl.pending.front());
  impl.pending.pop_front();
  impl.bookkeeping.AddInvalidRanges(next.invalid_ranges);
  impl.bookkeeping.Delivered(next.scan, impl.Where(next.entry));
  return std::move(next.scan);
}

const LogReaderStats& RawlogReader::Stats() const { return impl_->bookkeeping.stats(); }

}  // namespace shape_slam::io
