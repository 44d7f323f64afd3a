// shape-slam convert: a log (typically CARMEN) to an MRPT rawlog, observations-only or
// action-observation pairs, with the log's own timestamps (rawlog_writer.h).
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
                   "MRPT 2.5.8's carmen2rawlog overwrites the timestamps; this does not.\n"
                   "--format pairs writes the actions / sensory-frames layout instead, which\n"
                   "rbpf-slam and graphslam-engine need: per scan a CActionRobotMovement2D (the\n"
                   "odometry increment since the previous scan; zero for the first scan and\n"
                   "when the log has no odometry) and a CSensoryFrame with the scan.");
  parser.Positional("LOG", "input log")
      .Positional("OUT", "output rawlog (written atomically; an existing file is replaced only\n"
                         "when the conversion succeeded)")
      .Option("--format", {"LAYOUT"}, "observations or pairs (action-observation pairs)",
              "observations")
      .Flag("--strict", "fail on the first malformed log record instead of skipping it")
      .Flag("--quiet", "print nothing on success")
      .Epilog("Example:\n  shape-slam convert datasets/radish/intel.log.gz intel.rawlog\n"
              "  icp-slam my-icp.ini intel.rawlog");
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
#if SHAPE_SLAM_HAVE_MRPT
  const std::string format = parser.GetOptional("--format").value_or("observations");
  if (format != "observations" && format != "pairs") {
    throw UsageError("--format: '" + format + "' is neither observations nor pairs");
  }
  const std::unique_ptr<io::LogReader> reader =
      OpenLogForApp(parser.Get("LOG"), parser.Has("--strict"));
  const io::RawlogWriteStats stats = format == "pairs"
                                         ? io::WritePairsRawlog(*reader, parser.Get("OUT"))
                                         : io::WriteObservationsRawlog(*reader, parser.Get("OUT"));
  ReportLogIssues(*reader);
  if (!parser.Has("--quiet") && format == "pairs") {
    std::cout << parser.Get("OUT") << ": " << stats.scans << " action-observation pairs, "
              << stats.odometry << " scans with odometry, " << stats.bytes << " bytes\n";
  } else if (!parser.Has("--quiet")) {
    std::cout << parser.Get("OUT") << ": " << stats.scans << " laser scans, " << stats.odometry
              << " odometry observations, " << stats.bytes << " bytes\n";
  }
  return 0;
#else
  throw std::runtime_error("this shape-slam was built without MRPT: convert is not available");
#endif
}

}  // namespace shape_slam::app
