// shape-slam match: the pose of one scan in the frame of another, from the two scans alone
// (paper §4.2, §4.3, §5.1; core: scan_matcher.h).
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app_common.h"
#include "cli.h"
#include "commands.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/scan_matcher.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/json_writer.h"

namespace shape_slam::app {
namespace {

ArgParser MakeParser() {
  ArgParser parser("match",
                   "Estimates the pose of scan J in the frame of scan I (robot frames: x, y in\n"
                   "metres, theta in radians) by shape matching (paper §4.2; without a guess the\n"
                   "most reliable polyline pair seeds the alignment, §4.3), then point-to-line\n"
                   "alignment and Ceres refinement (§5.1). Odometry in the log is ignored: only\n"
                   "the two scans, and the guess when one is given, are used.");
  parser.Positional("LOG", "CARMEN log (.log/.clf[.gz]) or MRPT rawlog")
      .Option("--scan", {"I"}, "0-based index of the reference laser scan")
      .Option("--to", {"J"}, "0-based index of the scan whose pose is estimated")
      .Option("--guess", {"X", "Y", "THETA"}, "initial estimate of T_i_j (m, m, rad)")
      .Option("--config", {"FILE.ini"}, "parameters (see config/default.ini)")
      .Flag("--json", "print one JSON object instead of 'x y theta'")
      .Option("--svg", {"FILE"}, "draw scan I and scan J at the estimated pose")
      .Flag("--strict", "fail on the first malformed log record instead of skipping it")
      .Epilog("Output: one line 'x y theta'; with --json {\"T_i_j\": [x, y, theta], \"converged\",\n"
              "\"matched_pairs\", \"reliability\" (Q of eq. 5, null with a guess), \"iterations\",\n"
              "\"rms_error\" (m), \"inlier_ratio\", \"covariance\" (3x3, row-major)}.\n"
              "Exit code 0 when the match converged, 3 when it did not (the pose is then the\n"
              "guess or identity).\n\n"
              "Example:\n  shape-slam match datasets/radish/intel.log.gz --scan 100 --to 101 --json");
  return parser;
}

std::vector<Polyline> RobotFramePolylines(const LaserScan& scan, const Pose2& T_frame_robot,
                                          const ExtractionParams& params) {
  std::vector<Polyline> polylines = ExtractPolylines(scan, params);
  const Pose2 T = T_frame_robot * scan.T_robot_sensor;
  for (Polyline& p : polylines) {
    for (Point2& v : p) v = T * v;
  }
  return polylines;
}

}  // namespace

int RunMatch(const Args& args) {
  ArgParser parser = MakeParser();
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
  if (!parser.Has("--scan") || !parser.Has("--to")) throw UsageError("--scan I and --to J are required");
  const long long i = parser.GetIndex("--scan");
  const long long j = parser.GetIndex("--to");
  std::optional<Pose2> guess;
  if (parser.Has("--guess")) {
    const std::vector<double> v = parser.GetDoubles("--guess");
    guess = Pose2(v[0], v[1], v[2]);
  }
  const ShapeSlamParams params = LoadParamsForApp(parser.GetOptional("--config"));
  const std::vector<LaserScan> scans = ReadScansAt(parser.Get("LOG"), {i, j}, parser.Has("--strict"));
  const LaserScan& scan_i = scans[0];
  const LaserScan& scan_j = scans[1];
  const ScanMatchResult m = MatchScans(scan_i, scan_j, guess, ToScanMatchParams(params));

  if (const auto svg = parser.GetOptional("--svg")) {
    io::Drawing drawing;
    drawing.title = "scan " + std::to_string(j) + " on scan " + std::to_string(i);
    drawing.pixels_per_m = 60.0;
    drawing.layers.push_back({"scan " + std::to_string(i),
                              RobotFramePolylines(scan_i, Pose2(), params.shapes.extraction),
                              {}, {40, 90, 200}, 2.0, 1.0, false});
    drawing.layers.push_back({"scan " + std::to_string(j) + " at the estimate",
                              RobotFramePolylines(scan_j, m.T_i_j, params.shapes.extraction),
                              {}, {210, 40, 40}, 1.2, 1.0, false});
    io::WriteFileAtomically(*svg, io::RenderSvg(drawing));
  }
  if (parser.Has("--json")) {
    io::JsonWriter json;
    json.BeginObject().Key("scan").Value(i).Key("to").Value(j);
    json.Key("T_i_j").BeginArray().Value(m.T_i_j.x).Value(m.T_i_j.y).Value(m.T_i_j.theta).EndArray();
    json.Key("converged").Value(m.converged).Key("matched_pairs").Value(m.matched_pairs);
    json.Key("reliability").Value(m.reliability).Key("iterations").Value(m.iterations);
    json.Key("rms_error").Value(m.rms_error_m).Key("inlier_ratio").Value(m.inlier_ratio);
    json.Key("covariance").BeginArray();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) json.Value(m.covariance(r, c));
    }
    json.EndArray().EndObject();
    std::cout << json.str() << "\n";
  } else {
    std::ostringstream out;
    out << std::setprecision(9) << m.T_i_j.x << " " << m.T_i_j.y << " " << m.T_i_j.theta << "\n";
    std::cout << out.str();
    if (!m.converged) std::cerr << "shape-slam match: warning: the match did not converge\n";
  }
  return m.converged ? 0 : 3;
}

}  // namespace shape_slam::app
