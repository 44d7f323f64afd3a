// Reader of MRPT 2.x rawlogs (.rawlog, gzip or plain). Only available when ShapeSLAM is built
// with MRPT (SHAPE_SLAM_HAVE_MRPT); this header itself does not need MRPT.
//
// Both rawlog layouts are read, entry by entry (an entry is one top-level serialized object,
// numbered from 0):
//  - actions / sensory frames: a CActionCollection carries the odometry increment
//    (CActionRobotMovement2D, MRPT's best movement estimation, pose mean); T_odom_robot is the
//    product of the increments read so far, starting at identity. As in MRPT's
//    CRawlog::getActionObservationPairOrObservation, a CSensoryFrame is taken only after an
//    action collection: a sensory frame not preceded by one (e.g. the first entry of many
//    logs) is skipped, with an issue. Every CObservation2DRangeScan of a taken frame becomes
//    one LaserScan.
//  - observations only: CObservation2DRangeScan entries; CObservationOdometry gives absolute
//    odometry: a scan gets the latest one read before it (none before the first one).
// Both kinds of odometry update the same pose, so a log mixing them uses the latest.
// Other classes and observation types are skipped silently.
//
// CObservation2DRangeScan -> LaserScan by the shared conversion (mrpt_scan.h: validity, NaN and
// negative ranges, beam angles and order, maxRange, sensor pose); its invalid_ranges are counted
// in the reader's stats. Scans it rejects, and scans with no timestamp, are malformed records.
//
// A truncated or corrupt rawlog (MRPT throws while deserializing entry N, or the gzip stream is
// damaged): with LogReaderOptions::strict, LogError("file: entry N: ..."). Without it, when at
// least one scan was read, the stream ends at entry N with the issue recorded and counted in
// skipped_records (the usual state of a log whose recorder was killed); before the first scan
// it is a LogError in both modes. A rawlog cut exactly between two entries cannot be told from
// a complete one. The constructor reads up to the first scan, so a rawlog without any laser
// scan throws LogError at once.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "shape_slam_io/log_reader.h"

namespace shape_slam::io {

class RawlogReader final : public LogReader {
 public:
  /// Opens the rawlog and reads up to its first laser scan. Throws LogError.
  explicit RawlogReader(const std::string& path, const LogReaderOptions& options = {});
  ~RawlogReader() override;
  RawlogReader(const RawlogReader&) = delete;
  RawlogReader& operator=(const RawlogReader&) = delete;

  std::optional<LaserScan> Next() override;
  const LogReaderStats& Stats() const override;
  std::string Format() const override { return "rawlog"; }
  const std::string& Path() const override { return path_; }

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shape_slam::io
