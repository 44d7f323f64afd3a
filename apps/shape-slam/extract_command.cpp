// shape-slam extract: the polylines of one scan before and after DCE (paper §3.1).
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "app_common.h"
#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/json_writer.h"

namespace shape_slam::app {
namespace {

ArgParser MakeParser() {
  ArgParser parser("extract",
                   "Groups the points of one laser scan into polylines (split where consecutive\n"
                   "points are more than 0.20 m apart or at invalid/max-range readings) and\n"
                   "simplifies them by Discrete Curve Evolution (paper §3.1). Coordinates are in\n"
                   "the sensor frame, metres.");
  parser.Positional("LOG", "CARMEN log (.log/.clf[.gz]) or MRPT rawlog")
      .Option("--scan", {"K"}, "0-based index of the laser scan (other records do not count)", "0")
      .Option("--dce-threshold", {"T"},
              "DCE stop threshold on the relevance K of eq. (1), metres",
              std::to_string(DceParams{}.threshold_m))
      .Option("--max-gap", {"M"}, "split distance between consecutive points, metres", "0.20")
      .Flag("--json", "print one JSON object instead of text")
      .Option("--svg", {"FILE"}, "draw points, raw and simplified polylines with a 1 m grid")
      .Flag("--strict", "fail on the first malformed log record instead of skipping it")
      .Epilog("Example:\n  shape-slam extract datasets/radish/intel.log.gz --scan 10 --svg scan10.svg");
  return parser;
}

std::vector<Point2> ScanPoints(const LaserScan& scan, const ExtractionParams& params) {
  std::vector<Point2> points;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    const double r = scan.ranges_m[i];
    if (std::isfinite(r) && r > params.min_range_m && r < scan.max_range_m) {
      points.emplace_back(r * std::cos(scan.angles_rad[i]), r * std::sin(scan.angles_rad[i]));
    }
  }
  return points;
}

std::string Json(long long index, const LaserScan& scan, const std::vector<Polyline>& raw,
                 const std::vector<Polyline>& simplified) {
  io::JsonWriter json;
  json.BeginObject().Key("scan").Value(index).Key("timestamp").Value(scan.timestamp_s);
  json.Key("raw_polylines").BeginArray();
  for (const Polyline& p : raw) json.Value(p);
  json.EndArray().Key("polylines").BeginArray();
  for (const Polyline& p : simplified) json.Value(p);
  json.EndArray().EndObject();
  return json.str() + "\n";
}

std::string Text(long long index, const LaserScan& scan, const std::vector<Polyline>& raw,
                 const std::vector<Polyline>& simplified, double threshold_m) {
  std::size_t raw_points = 0, vertices = 0;
  for (const Polyline& p : raw) raw_points += p.size();
  for (const Polyline& p : simplified) vertices += p.size();
  std::ostringstream out;
  out << std::fixed << std::setprecision(6) << "scan " << index << " at t=" << scan.timestamp_s
      << " s: " << scan.ranges_m.size() << " beams, " << raw.size() << " polylines ("
      << raw_points << " points) -> " << vertices << " vertices after DCE (threshold "
      << std::setprecision(3) << threshold_m << " m)\n";
  for (std::size_t i = 0; i < simplified.size(); ++i) {
    out << "polyline " << i << ": " << raw[i].size() << " points -> " << simplified[i].size()
        << " vertices:";
    for (const Point2& p : simplified[i]) out << " (" << p.x() << ", " << p.y() << ")";
    out << "\n";
  }
  return out.str();
}

io::Drawing MakeDrawing(long long index, const std::vector<Point2>& points,
                        const std::vector<Polyline>& raw, const std::vector<Polyline>& simplified) {
  io::Drawing drawing;
  drawing.title = "scan " + std::to_string(index) + " (sensor frame)";
  drawing.pixels_per_m = 80.0;
  drawing.layers.push_back({"scan points", {}, points, {150, 150, 150}, 1.0, 1.6, false});
  drawing.layers.push_back({"raw polylines", raw, {}, {120, 170, 230}, 1.0, 1.0, false});
  drawing.layers.push_back({"after DCE", simplified, {}, {200, 30, 30}, 2.0, 1.0, true});
  drawing.layers.push_back({"sensor", {}, {Point2::Zero()}, {0, 120, 0}, 1.0, 4.0, false});
  return drawing;
}

}  // namespace

int RunExtract(const Args& args) {
  ArgParser parser = MakeParser();
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
  const long long index = parser.Has("--scan") ? parser.GetIndex("--scan") : 0;
  DceParams dce;
  dce.threshold_m = parser.GetDouble("--dce-threshold", dce.threshold_m);
  ExtractionParams extraction;
  extraction.max_gap_m = parser.GetDouble("--max-gap", extraction.max_gap_m);
  try {
    dce.Validate();
    extraction.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const LaserScan scan = ReadScanAt(parser.Get("LOG"), index, parser.Has("--strict"));
  const std::vector<Polyline> raw = ExtractPolylines(scan, extraction);
  std::vector<Polyline> simplified;
  for (const Polyline& p : raw) simplified.push_back(SimplifyDce(p, dce.threshold_m));
  if (const auto svg = parser.GetOptional("--svg")) {
    io::WriteFileAtomically(
        *svg, io::RenderSvg(MakeDrawing(index, ScanPoints(scan, extraction), raw, simplified)));
  }
  std::cout << (parser.Has("--json") ? Json(index, scan, raw, simplified)
                                     : Text(index, scan, raw, simplified, dce.threshold_m));
  return 0;
}

}  // namespace shape_slam::app
