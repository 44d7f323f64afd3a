// Writers of MRPT rawlogs (built only with MRPT): what `shape-slam convert` makes of a CARMEN
// log, so that MRPT's own apps (icp-slam, rbpf-slam, graphslam-engine, RawLogViewer...) can run
// on it. Two layouts:
//
// Observations-only (WriteObservationsRawlog): for every scan, in log order: a CObservationOdometry (sensorLabel "ODOMETRY", the absolute
// odometry pose T_odom_robot) when the scan has one, then a CObservation2DRangeScan (sensorLabel
// "LASER"). Both carry the scan's timestamp, converted exactly as mrpt::Clock::fromDouble does
// (MRPT's time base has a resolution of 100 ns). MRPT 2.5.8's own carmen2rawlog writes the
// conversion time instead of the log's timestamps.
//
// Actions / sensory frames (WritePairsRawlog), what rbpf-slam and graphslam-engine need: for
// every scan a CActionCollection holding one CActionRobotMovement2D, the odometry increment
// T_prev_robot from the previous scan's odometry pose to this scan's (MRPT's default motion
// model options: a Gaussian), then a CSensoryFrame holding the CObservation2DRangeScan. Both
// carry the scan's timestamp. The first scan's increment is zero, and so is the increment of a
// scan without odometry (and every increment of a log whose odometry is all zero): such a log
// gives these apps no motion prior at all.
//
// Beam geometry: CObservation2DRangeScan spreads N beams evenly over [-aperture/2,
// +aperture/2] around the sensor's x axis. A scan whose beams are evenly spaced but not
// centred on 0 (CARMEN's FLASER with an even beam count covers -90 deg .. +89 deg) is stored
// with aperture = last - first and the sensor yaw turned by (first + last) / 2, so every beam
// keeps its exact direction in the robot frame. Scans whose beams are not evenly spaced
// (within 1e-6 rad) cannot be represented: LogError.
//
// Ranges: NaN readings are stored as 0 and marked invalid; readings >= max_range_m ("no
// return") keep their value and are marked invalid, as MRPT's scanners do.
#pragma once

#include <cstddef>
#include <string>

#include "shape_slam_io/log_reader.h"

namespace shape_slam::io {

struct RawlogWriteStats {
  std::size_t scans = 0;
  std::size_t odometry = 0;  ///< scans with an odometry pose
  std::size_t bytes = 0;
};

/// Reads every scan of `reader` and writes the rawlog to `path` atomically (uncompressed; MRPT
/// reads plain and gzip rawlogs alike). Throws LogError (reader, unrepresentable beams) or
/// OutputError (atomic_file.h).
RawlogWriteStats WriteObservationsRawlog(LogReader& reader, const std::string& path);

/// The same in the actions / sensory-frames layout: one action-observation pair per scan.
RawlogWriteStats WritePairsRawlog(LogReader& reader, const std::string& path);

}  // namespace shape_slam::io
