// shape-slam extract: one scan's shapes as the mapper, the scan matcher and the localizer see
// them (ExtractScanShapes, paper §3.1): the polylines as grouped, as shape matching compares
// them, and as the alignment samples them.
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "app_common.h"
#include "shape_slam/pipeline.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/scan_shapes.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/json_writer.h"

namespace shape_slam::app {
namespace {

ArgParser MakeParser() {
  ArgParser parser("extract",
                   "One laser scan's shapes exactly as the mapper, `match` and `localize` see them\n"
                   "(ExtractScanShapes, paper §3.1): the points grouped into polylines (split\n"
                   "where consecutive points are farther apart than max_gap_m, widened with the\n"
                   "range, or at invalid/max-range readings), simplified by Discrete Curve\n"
                   "Evolution to the shapes matching compares (at most max_shape_vertices\n"
                   "vertices) and, lightly, to the polylines the alignment samples. The beams are\n"
                   "taken counter-clockwise first, as the mapper does. Coordinates are in the\n"
                   "sensor frame, metres.");
  parser.Positional("LOG", "CARMEN log (.log/.clf[.gz]) or MRPT rawlog")
      .Option("--scan", {"K"}, "0-based index of the laser scan (other records do not count)", "0")
      .Option("--config", {"FILE.ini"},
              "parameters (config/default.ini: [extraction], [dce], shape keys of [pipeline])")
      .Option("--dce-threshold", {"T"},
              "DCE stop threshold on the relevance K of eq. (1), metres (overrides the config)",
              std::to_string(ShapeSlamParams{}.shapes.dce.threshold_m))
      .Option("--max-gap", {"M"},
              "split distance between consecutive points, metres (overrides the config)",
              std::to_string(ShapeSlamParams{}.shapes.extraction.max_gap_m))
      .Flag("--json", "print one JSON object instead of text")
      .Option("--svg", {"FILE"},
              "draw points, grouped, matching and alignment polylines with a 1 m grid")
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

// The grouped polylines (ExtractScanShapes' input) and its two outputs, index by index.
struct Extracted {
  std::vector<Polyline> raw;
  ScanShapes shapes;
};

void JsonArray(io::JsonWriter& json, const char* key, const std::vector<Polyline>& polylines) {
  json.Key(key).BeginArray();
  for (const Polyline& p : polylines) json.Value(p);
  json.EndArray();
}

std::string Json(long long index, const LaserScan& scan, const Extracted& e) {
  io::JsonWriter json;
  json.BeginObject().Key("scan").Value(index).Key("timestamp").Value(scan.timestamp_s);
  JsonArray(json, "raw_polylines", e.raw);
  JsonArray(json, "polylines", e.shapes.coarse);
  JsonArray(json, "alignment_polylines", e.shapes.fine);
  json.EndObject();
  return json.str() + "\n";
}

std::size_t Vertices(const std::vector<Polyline>& polylines) {
  std::size_t n = 0;
  for (const Polyline& p : polylines) n += p.size();
  return n;
}

std::string Text(long long index, const LaserScan& scan, const Extracted& e,
                 const ScanShapesParams& params) {
  const std::vector<Polyline>& coarse = e.shapes.coarse;
  std::ostringstream out;
  out << std::fixed << std::setprecision(6) << "scan " << index << " at t=" << scan.timestamp_s
      << " s: " << scan.ranges_m.size() << " beams, " << e.raw.size() << " polylines ("
      << Vertices(e.raw) << " points) -> " << Vertices(coarse)
      << " vertices for shape matching (DCE threshold " << std::setprecision(3)
      << params.dce.threshold_m << " m, at most " << params.max_shape_vertices
      << " per polyline), " << Vertices(e.shapes.fine) << " for the alignment\n";
  for (std::size_t i = 0; i < coarse.size(); ++i) {
    out << "polyline " << i << ": " << e.raw[i].size() << " points -> " << coarse[i].size()
        << " vertices:";
    for (const Point2& p : coarse[i]) out << " (" << p.x() << ", " << p.y() << ")";
    out << "\n";
  }
  return out.str();
}

io::Drawing MakeDrawing(long long index, const std::vector<Point2>& points, const Extracted& e) {
  io::Drawing drawing;
  drawing.title = "scan " + std::to_string(index) + " (sensor frame)";
  drawing.pixels_per_m = 80.0;
  drawing.layers.push_back({"scan points", {}, points, {150, 150, 150}, 1.0, 1.6, false});
  drawing.layers.push_back({"grouped polylines", e.raw, {}, {120, 170, 230}, 1.0, 1.0, false});
  drawing.layers.push_back({"alignment", e.shapes.fine, {}, {230, 150, 40}, 1.0, 1.0, false});
  drawing.layers.push_back({"shape matching", e.shapes.coarse, {}, {200, 30, 30}, 2.0, 1.0, true});
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
  ScanShapesParams params = LoadParamsForApp(parser.GetOptional("--config")).shapes;
  params.dce.threshold_m = parser.GetDouble("--dce-threshold", params.dce.threshold_m);
  params.extraction.max_gap_m = parser.GetDouble("--max-gap", params.extraction.max_gap_m);
  try {
    params.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const LaserScan scan =
      CounterClockwiseScan(ReadScanAt(parser.Get("LOG"), index, parser.Has("--strict")));
  const Extracted extracted{ExtractPolylines(scan, params.extraction),
                            ExtractScanShapes(scan, params)};
  if (const auto svg = parser.GetOptional("--svg")) {
    io::WriteFileAtomically(
        *svg, io::RenderSvg(MakeDrawing(index, ScanPoints(scan, params.extraction), extracted)));
  }
  std::cout << (parser.Has("--json") ? Json(index, scan, extracted)
                                     : Text(index, scan, extracted, params));
  return 0;
}

}  // namespace shape_slam::app
