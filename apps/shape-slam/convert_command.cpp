// shape-slam convert: a log (typically CARMEN) to an observations-only MRPT rawlog, with the
// log's own timestamps (rawlog_writer.h).
#include <iostream>

#include "app_common.h"
#include "cli.h"
#include "commands.h"
#if SHAPE_SLAM_HAVE_MRPT
#include "shape_slam_io/rawlog_writer.h"
#endif

namespace shape_slam::app {

int RunConvert(const Args& args) {
  ArgParser parser("convert",
                   "Converts a log (CARMEN .log/.clf[.gz], or a rawlog of the other layout) into\n"
                   "an observations-only MRPT rawlog: per scan a CObservationOdometry (absolute\n"
                   "odometry, when the log has it) and a CObservation2DRangeScan, with the log's\n"
                   "timestamps, exact beam directions and the laser's offset on the robot.\n"
                   "MRPT 2.5.8's carmen2rawlog overwrites the timestamps; this does not.");
  parser.Positional("LOG", "input log")
      .Positional("OUT", "output rawlog (written atomically; an existing file is replaced only\n"
                         "when the conversion succeeded)")
      .Flag("--strict", "fail on the first malformed log record instead of skipping it")
      .Flag("--quiet", "print nothing on success")
      .Epilog("Example:\n  shape-slam convert datasets/radish/intel.log.gz intel.rawlog\n"
              "  icp-slam my-icp.ini intel.rawlog");
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
#if SHAPE_SLAM_HAVE_MRPT
  const std::unique_ptr<io::LogReader> reader =
      OpenLogForApp(parser.Get("LOG"), parser.Has("--strict"));
  const io::RawlogWriteStats stats = io::WriteObservationsRawlog(*reader, parser.Get("OUT"));
  ReportLogIssues(*reader);
  if (!parser.Has("--quiet")) {
    std::cout << parser.Get("OUT") << ": " << stats.scans << " laser scans, " << stats.odometry
              << " odometry observations, " << stats.bytes << " bytes\n";
  }
  return 0;
#else
  throw std::runtime_error("this shape-slam was built without MRPT: convert is not available");
#endif
}

}  // namespace shape_slam::app
