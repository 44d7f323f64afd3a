// Reader of CARMEN text logs (.log/.clf, plain or gzip, read through zlib).
//
// Records read (one per line, fields separated by white space):
//  - FLASER n r_1..r_n x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
//    n front-laser readings (metres) over a 180 deg field of view: beam i points at
//    -90 deg + i * 180 deg / n when n is even (180, 360) and -90 deg + i * 180 deg / (n - 1)
//    when n is odd (181, 361). `x y theta` is the laser pose (checked, not used), `odom_*` the
//    robot's odometry pose -> LaserScan::T_odom_robot. timestamp_s = `timestamp`, unchanged
//    (not logger_timestamp). Older variants that end after `timestamp` or after `host` are
//    accepted too.
//  - ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode n
//    r_1..r_n n_rem rem_1..rem_n_rem laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
//    fwd_safety side_safety turn_axis timestamp host logger_timestamp
//    beam i at start_angle + i * angular_res; max_range from the record; T_odom_robot =
//    robot pose; T_robot_sensor = T_odom_robot^-1 * T_odom_laser.
//    When a log holds ROBOTLASER1 records, its FLASER records (the same front laser, in the
//    older message) are ignored, so that no scan is delivered twice; an issue says so.
//  - PARAM name value ...: robot_frontlaser_offset V -> T_robot_sensor = (V, 0, 0) for FLASER
//    scans (default 0); laser_front_laser_max_range V, else robot_front_laser_max V ->
//    max_range_m of FLASER scans. The first value of a name in the file wins, wherever it is.
//    Other PARAMs, ODOM (FLASER and ROBOTLASER1 carry the odometry pose already) and every
//    other message type are ignored.
//
// FLASER max range: FLASER gives none, so when no PARAM does, it is found from the data. Let L
// be the largest reading of the log's well-formed FLASER records. If L >= 20 m and at least
// 0.1 % of all their readings lie within max(0.005 m, 0.5 % of L) below L, those readings are
// the scanner's "no return" value and max_range_m = (the smallest of them reached from L in
// steps of at most 0.05 m) - 0.005 (so that
// `r >= max_range_m` flags them); otherwise max_range_m = L + 1 (nothing flagged). Radish logs
// use 50 (aces), 81.83 (intel), 81.91 (freiburg-079) and 51.01-51.16 (infinite-corridor) for
// "no return".
//
// Readings: NaN, inf or negative readings become NaN ("no reading") and are counted in
// LogReaderStats::invalid_ranges. Numbers are parsed independently of the C locale.
//
// Malformed records (wrong number of fields, a non-number where a number belongs, n < 1 or
// n > 100000, a non-finite pose or timestamp, a bad value of one of the PARAMs above): with
// LogReaderOptions::strict the first one throws LogError("file:line: ..."), otherwise they are
// skipped, counted and recorded as issues. Timestamps going backwards are counted and recorded,
// never an error.
//
// The constructor reads the whole file once (PARAMs, the max-range rule, integrity of the gzip
// stream, at least one laser record, and in strict mode every record), then Next() streams the
// scans in a second pass. Errors that always throw LogError: missing path, directory, empty
// file, binary content ("not a CARMEN log"), corrupt or truncated gzip data (naming the line
// where the data stops), no laser record at all.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "shape_slam_io/log_reader.h"

namespace shape_slam::io {

class CarmenReader final : public LogReader {
 public:
  /// Opens and surveys the log (see above). Throws LogError.
  explicit CarmenReader(const std::string& path, const LogReaderOptions& options = {});
  ~CarmenReader() override;
  CarmenReader(const CarmenReader&) = delete;
  CarmenReader& operator=(const CarmenReader&) = delete;

  std::optional<LaserScan> Next() override;
  const LogReaderStats& Stats() const override;
  std::string Format() const override { return "carmen"; }
  const std::string& Path() const override { return path_; }

  /// The max range given to FLASER scans (from a PARAM or the rule above), metres.
  double flaser_max_range_m() const;

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shape_slam::io
