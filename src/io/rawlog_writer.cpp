#include "shape_slam_io/rawlog_writer.h"

#include <mrpt/core/Clock.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <string>

#include "mrpt_scan_internal.h"
#include "shape_slam_io/atomic_file.h"

namespace shape_slam::io {
namespace internal {

constexpr double kEvenSpacingTolerance = 1e-6;  // rad

mrpt::obs::CObservation2DRangeScan ToMrptScan(const LaserScan& scan, std::size_t index) {
  const std::size_t n = scan.ranges_m.size();
  if (n == 0 || scan.angles_rad.size() != n) {
    throw LogError("scan " + std::to_string(index) + ": no beams or angles/ranges mismatch");
  }
  const double first = scan.angles_rad.front();
  const double last = scan.angles_rad.back();
  const double step = n > 1 ? (last - first) / static_cast<double>(n - 1) : 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::abs(scan.angles_rad[i] - (first + step * static_cast<double>(i))) >
        kEvenSpacingTolerance) {
      throw LogError("scan " + std::to_string(index) +
                     ": beams are not evenly spaced, an MRPT 2D range scan cannot hold them");
    }
  }
  mrpt::obs::CObservation2DRangeScan obs;
  obs.sensorLabel = "LASER";
  obs.timestamp = mrpt::Clock::fromDouble(scan.timestamp_s);
  obs.rightToLeft = step >= 0.0;
  obs.aperture = static_cast<float>(std::abs(last - first));
  obs.maxRange = static_cast<float>(scan.max_range_m);
  const Pose2 centre = scan.T_robot_sensor * Pose2(0.0, 0.0, 0.5 * (first + last));
  obs.sensorPose = mrpt::poses::CPose3D(centre.x, centre.y, 0.0, centre.theta, 0.0, 0.0);
  obs.resizeScan(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = scan.ranges_m[i];
    const bool valid = std::isfinite(r) && r > 0.0 && r < scan.max_range_m;
    obs.setScanRange(i, std::isfinite(r) && r > 0.0 ? static_cast<float>(r) : 0.0f);
    obs.setScanRangeValidity(i, valid);
  }
  return obs;
}

}  // namespace internal

namespace {

// The odometry increment T_prev_robot from the previous scan's odometry pose (default motion
// model options: a Gaussian whose spread grows with the increment) as an action collection.
mrpt::obs::CActionCollection OdometryAction(const Pose2& T_prev_robot, double timestamp_s) {
  mrpt::obs::CActionRobotMovement2D movement;
  movement.timestamp = mrpt::Clock::fromDouble(timestamp_s);
  movement.computeFromOdometry(
      mrpt::poses::CPose2D(T_prev_robot.x, T_prev_robot.y, T_prev_robot.theta),
      mrpt::obs::CActionRobotMovement2D::TMotionModelOptions());
  mrpt::obs::CActionCollection actions;
  actions.insert(movement);
  return actions;
}

std::size_t WriteBufferAtomically(const mrpt::io::CMemoryStream& buffer, const std::string& path) {
  const auto* data = static_cast<const char*>(buffer.getRawBufferData());
  const std::string content(data, data + buffer.getTotalBytesCount());
  WriteFileAtomically(path, content);
  return content.size();
}

}  // namespace

RawlogWriteStats WriteObservationsRawlog(LogReader& reader, const std::string& path) {
  mrpt::io::CMemoryStream buffer;
  auto archive = mrpt::serialization::archiveFrom(buffer);
  RawlogWriteStats stats;
  while (const std::optional<LaserScan> scan = reader.Next()) {
    if (scan->T_odom_robot) {
      mrpt::obs::CObservationOdometry odometry;
      odometry.sensorLabel = "ODOMETRY";
      odometry.timestamp = mrpt::Clock::fromDouble(scan->timestamp_s);
      const Pose2& p = *scan->T_odom_robot;
      odometry.odometry = mrpt::poses::CPose2D(p.x, p.y, p.theta);
      archive << odometry;
      ++stats.odometry;
    }
    archive << internal::ToMrptScan(*scan, stats.scans);
    ++stats.scans;
  }
  stats.bytes = WriteBufferAtomically(buffer, path);
  return stats;
}

RawlogWriteStats WritePairsRawlog(LogReader& reader, const std::string& path) {
  mrpt::io::CMemoryStream buffer;
  auto archive = mrpt::serialization::archiveFrom(buffer);
  RawlogWriteStats stats;
  std::optional<Pose2> T_odom_prev;
  while (const std::optional<LaserScan> scan = reader.Next()) {
    Pose2 T_prev_robot;  // zero without odometry, and for the first scan
    if (scan->T_odom_robot) {
      if (T_odom_prev) T_prev_robot = T_odom_prev->Inverse() * *scan->T_odom_robot;
      T_odom_prev = scan->T_odom_robot;
      ++stats.odometry;
    }
    archive << OdometryAction(T_prev_robot, scan->timestamp_s);
    mrpt::obs::CSensoryFrame frame;
    frame.insert(std::make_shared<mrpt::obs::CObservation2DRangeScan>(
        internal::ToMrptScan(*scan, stats.scans)));
    archive << frame;
    ++stats.scans;
  }
  stats.bytes = WriteBufferAtomically(buffer, path);
  return stats;
}

}  // namespace shape_slam::io
