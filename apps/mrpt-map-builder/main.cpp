// mrpt-map-builder: an MRPT rawlog through shape_slam::CMetricMapBuilderShape, fed as icp-slam
// feeds mrpt::slam::CMetricMapBuilderICP (one call per rawlog entry: processActionObservation
// or processObservation, then getCurrentPoseEstimation). An example of the builder in a program
// written for MRPT's map builders; `shape-slam run` is the full tool.
#include <mrpt/config/CConfigFile.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/poses/CPose3DPDF.h>
#include <mrpt/serialization/CArchive.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/map_file.h"
#include "shape_slam_io/trajectory_io.h"
#include "shape_slam_mrpt/map_builder_shape.h"
#include "shape_slam_mrpt/plugin.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace {

constexpr const char* kUsage =
    "usage: mrpt-map-builder [--config MRPT.ini [--section NAME]] [--out DIR] [--no-odometry]\n"
    "                        [--max-entries N] LOG.rawlog\n"
    "\n"
    "Maps an MRPT rawlog (actions + sensory frames, or observations only) with\n"
    "shape_slam::CMetricMapBuilderShape, fed entry by entry as icp-slam feeds\n"
    "CMetricMapBuilderICP (a sensory frame with no action before it, which icp-slam\n"
    "drops, is fed with an empty action collection, as shape-slam run uses it).\n"
    "\n"
    "  --config FILE   MRPT ini; keys of --section: params_file (a ShapeSLAM parameter\n"
    "                  ini, config/default.ini), use_odometry (true/false)\n"
    "  --section NAME  default MappingApplication\n"
    "  --out DIR       output directory (default ./mrpt-map-builder-out), created if needed\n"
    "  --no-odometry   ignore the log's odometry (use_odometry = false)\n"
    "  --max-entries N process only the first N steps (action + frame, or observation)\n"
    "\n"
    "Outputs in DIR:\n"
    "  log_estimated_path.txt  `step x y phi` after every rawlog entry (as icp-slam's)\n"
    "  trajectory.tum          every scan at its final (loop-corrected) pose, log time\n"
    "  map.polylines, map.png  the map (shape-slam's map file) and a picture with the path\n"
    "  map.simplemap           the keyframes at their corrected poses (CSimpleMap, gzip)\n";

struct Args {
  std::string log, config, section = "MappingApplication", out = "mrpt-map-builder-out";
  bool no_odometry = false;
  long long max_entries = -1;
};

Args Parse(int argc, char** argv) {
  Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (a == "--config") {
      args.config = value();
    } else if (a == "--section") {
      args.section = value();
    } else if (a == "--out") {
      args.out = value();
    } else if (a == "--no-odometry") {
      args.no_odometry = true;
    } else if (a == "--max-entries") {
      args.max_entries = std::stoll(value());
    } else if (!a.empty() && a[0] == '-') {
      throw std::invalid_argument("unknown option " + a);
    } else if (args.log.empty()) {
      args.log = a;
    } else {
      throw std::invalid_argument("more than one LOG given");
    }
  }
  if (args.log.empty()) throw std::invalid_argument("no LOG given");
  return args;
}

void Configure(shape_slam::CMetricMapBuilderShape& builder, const Args& args) {
  if (!args.config.empty()) {
    builder.LoadOptions(mrpt::config::CConfigFile(args.config), args.section);
  }
  if (args.no_odometry) {
    shape_slam::CMetricMapBuilderShape::Options options = builder.GetOptions();
    options.params.use_odometry = false;
    builder.SetOptions(options);
  }
}

// icp-slam's main loop (one step per action collection + sensory frame, or per observation),
// reading the entries one by one as CRawlog does, with one difference: a sensory frame with no
// action collection before it (MRPT's sample log starts with one) is processed with an empty
// action collection (CMetricMapBuilderShape::ProcessRawlogEntry), where
// CRawlog::getActionObservationPairOrObservation drops it, so that the builder sees every scan
// `shape-slam run` maps. Returns the `step x y phi` lines.
std::string RunLog(shape_slam::CMetricMapBuilderShape& builder, const Args& args) {
  mrpt::io::CFileGZInputStream file(args.log);
  auto archive = mrpt::serialization::archiveFrom(file);
  std::ostringstream path;
  for (long long step = 0; args.max_entries < 0 || step < args.max_entries;) {
    mrpt::serialization::CSerializable::Ptr entry;
    try {
      archive >> entry;
    } catch (const mrpt::serialization::CExceptionEOF&) {
      break;  // the end of the log
    }
    if (!builder.ProcessRawlogEntry(entry)) continue;  // an action collection, or other
    const mrpt::poses::CPose3D pose = builder.getCurrentPoseEstimation()->getMeanVal();
    char line[128];
    std::snprintf(line, sizeof(line), "%lld %f %f %f\n", step, pose.x(), pose.y(), pose.yaw());
    path << line;
    ++step;
  }
  return path.str();
}

void WriteOutputs(shape_slam::CMetricMapBuilderShape& builder, const Args& args,
                  const std::string& path_text) {
  namespace io = shape_slam::io;
  io::EnsureDirectory(args.out);
  io::WriteFileAtomically(args.out + "/log_estimated_path.txt", path_text);
  std::vector<shape_slam::StampedPose> trajectory = builder.Mapper().Trajectory();
  for (shape_slam::StampedPose& p : trajectory) p.pose = builder.WorldFromMap() * p.pose;
  io::WriteFileAtomically(args.out + "/trajectory.tum", io::FormatTum(trajectory));
  const auto map = builder.getCurrentlyBuiltMetricMap()->mapByClass<shape_slam::CPolylineMap>();
  io::SaveMapFile(args.out + "/map.polylines", map->Map());
  builder.saveCurrentEstimationToImage(args.out + "/map.png");
  builder.saveCurrentMapToFile(args.out + "/map.simplemap");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args args = Parse(argc, argv);
    shape_slam::RegisterMrptClasses();
    shape_slam::CMetricMapBuilderShape builder;
    builder.setMinLoggingLevel(mrpt::system::LVL_WARN);  // MRPT's "saving map" notes
    Configure(builder, args);
    const std::string path_text = RunLog(builder, args);
    builder.Finish();  // final pose-graph optimisation, as `shape-slam run` does
    WriteOutputs(builder, args, path_text);
    const auto& slam = builder.Mapper();
    std::cout << slam.Trajectory().size() << " scans, " << builder.getCurrentlyBuiltMapSize()
              << " keyframes, " << slam.Map().NumPolylines() << " polylines, "
              << slam.NumLoopClosures() << " loop closures, odometry "
              << shape_slam::ToString(slam.Odometry().status) << ", " << builder.SkippedScans()
              << " scans skipped; outputs in " << args.out << "\n";
    return 0;
  } catch (const std::invalid_argument& e) {
    std::cerr << "mrpt-map-builder: " << e.what() << "\n(--help for usage)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "mrpt-map-builder: " << e.what() << "\n";
    return 1;
  }
}
