// shape-slam localize: localization of a log in a saved map.polylines (the map is unchanged).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "app_common.h"
#include "cli.h"
#include "commands.h"
#include "progress.h"
#include "shape_slam/localizer.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/json_writer.h"
#include "shape_slam_io/map_file.h"
#include "shape_slam_io/params_ini.h"
#include "shape_slam_io/trajectory_io.h"

namespace shape_slam::app {
namespace {

ArgParser MakeParser() {
  ArgParser parser("localize",
                   "Localizes the robot of a laser log in a saved polyline map, which is left\n"
                   "unchanged. Without --initial the robot is found by a global search over the\n"
                   "whole map; while look-alike places explain the scans equally well it waits\n"
                   "for more scans. It then tracks the pose against the visible map (paper\n"
                   "§3-§5.1), notices when it is lost (or carried away) and searches again.");
  parser.Positional("MAP", "map.polylines written by 'shape-slam run'")
      .Positional("LOG", "CARMEN log (.log/.clf[.gz]) or MRPT rawlog")
      .Option("--initial", {"X", "Y", "THETA"}, "the robot's first pose in the map (m, m, rad)")
      .Option("--config", {"FILE.ini"},
              "parameters: the mapper's stages and [localizer] (config/default.ini has every key)")
      .Option("--out", {"DIR"}, "output directory", "./shape-slam-localize")
      .Flag("--no-odometry", "ignore the log's odometry: match by shape alone (paper §4.3)")
      .Option("--max-scans", {"N"}, "process only the first N laser scans")
      .Flag("--quiet", "no progress bar and no summary")
      .Flag("--strict", "fail on the first malformed log record instead of skipping it")
      .Epilog(
          "Outputs (written atomically into DIR, all together, only after a successful run):\n"
          "  trajectory.tum   one line per localized scan: timestamp x y z qx qy qz qw\n"
          "  map.svg, map.png the map with the localized trajectory (blue, apart where\n"
          "                   the robot was not localized; start green, end red) and\n"
          "                   where it was lost (orange)\n"
          "  stats.json       scans, localized fraction, first localized scan, lost and\n"
          "                   recovered events, per-scan times, status counts\n"
          "  status.csv       one row per scan: scan, timestamp, status (searching,\n"
          "                   ambiguous, tracking, lost), localized, matched, x y theta (the\n"
          "                   pose or best hypothesis; empty without one), inlier_ratio,\n"
          "                   hypotheses, lost_event, recovered_event, rechecked (the\n"
          "                   map's check moved the pose), field_tracked (without\n"
          "                   odometry, the map's field predicted the scan), ms\n\n"
          "Example:\n"
          "  shape-slam run intel.log.gz --out intel-out\n"
          "  shape-slam localize intel-out/map.polylines intel.log.gz --out intel-loc");
  return parser;
}

struct LocalizeOutput {
  std::vector<StampedPose> trajectory;  // localized scans only
  std::vector<Polyline> pieces;         // the localized stretches' positions (for the picture)
  std::vector<Point2> lost_at;          // the pose of each scan that declared the robot lost
  std::string status_csv;               // one row per scan
  std::vector<double> scan_ms;
  std::size_t scans = 0, localized = 0, matched = 0;
  long long first_localized = -1;
  int lost_events = 0, recovered_events = 0, rechecks = 0, field_tracked = 0;
  std::size_t status_counts[4] = {0, 0, 0, 0};
  double processing_s = 0.0;
  double heading_per_m = 0.0, heading_per_rad = 0.0;  // learned (OdometryCalibrator)
};

constexpr const char* kStatusHeader =
    "scan,timestamp,status,localized,matched,x,y,theta,inlier_ratio,hypotheses,lost_event,"
    "recovered_event,rechecked,field_tracked,ms\n";

// One status.csv row. Without a pose or hypothesis (searching with none yet) x, y, theta are
// empty.
std::string StatusRow(std::size_t scan, const LocalizerReport& r, double ms) {
  std::ostringstream row;
  row << std::setprecision(10) << scan << ',' << r.timestamp_s << ',' << ToString(r.status) << ','
      << r.localized << ',' << r.matched << ',';
  if (r.localized || r.hypotheses > 0) {
    row << r.T_map_robot.x << ',' << r.T_map_robot.y << ',' << r.T_map_robot.theta;
  } else {
    row << ",,";
  }
  row << ',' << std::setprecision(4) << r.inlier_ratio << ',' << r.hypotheses << ','
      << r.lost_event << ',' << r.recovered_event << ',' << r.rechecked << ','
      << r.field_tracked << ',' << ms << '\n';
  return row.str();
}

LocalizeOutput RunLocalizer(Localizer& localizer, const std::vector<LaserScan>& scans, bool quiet) {
  LocalizeOutput out;
  out.status_csv = kStatusHeader;
  ProgressBar progress(scans.size(), "localizing", !quiet);
  const auto start = std::chrono::steady_clock::now();
  bool localized_before = false;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const LocalizerReport report = localizer.Process(scans[i]);
    const auto t1 = std::chrono::steady_clock::now();
    out.scan_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    out.status_csv += StatusRow(i, report, out.scan_ms.back());
    ++out.status_counts[static_cast<int>(report.status)];
    if (report.localized) {
      if (!localized_before || report.recovered_event) out.pieces.emplace_back();
      out.pieces.back().push_back(report.T_map_robot.Translation());
      out.trajectory.push_back({report.timestamp_s, report.T_map_robot});
      ++out.localized;
      if (out.first_localized < 0) out.first_localized = static_cast<long long>(i);
    }
    out.matched += report.matched ? 1 : 0;
    out.lost_events += report.lost_event ? 1 : 0;
    if (report.lost_event) out.lost_at.push_back(report.T_map_robot.Translation());
    localized_before = report.localized;
    out.recovered_events += report.recovered_event ? 1 : 0;
    out.rechecks += report.rechecked ? 1 : 0;
    out.field_tracked += report.field_tracked ? 1 : 0;
    progress.Update(i + 1);
  }
  progress.Finish();
  out.scans = scans.size();
  out.processing_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.heading_per_m = localizer.OdometryCalibration().HeadingPerMetre();
  out.heading_per_rad = localizer.OdometryCalibration().HeadingPerRadian();
  return out;
}


double LocalizedFraction(const LocalizeOutput& out) {
  return out.scans == 0 ? 0.0 : static_cast<double>(out.localized) / out.scans;
}

std::string StatsJson(const LocalizeOutput& out, const std::string& map_path,
                      const io::LogReader& reader, bool initial, double wall_s) {
  io::JsonWriter json;
  json.BeginObject().Key("scans").Value(out.scans);
  json.Key("map").Value(map_path).Key("initial_pose_given").Value(initial);
  json.Key("wall_s").Value(wall_s).Key("processing_s").Value(out.processing_s);
  json.Key("per_scan_ms").BeginObject();
  json.Key("median").Value(Percentile(out.scan_ms, 0.5)).Key("p95").Value(Percentile(out.scan_ms, 0.95));
  json.Key("max").Value(out.scan_ms.empty() ? 0.0 : *std::max_element(out.scan_ms.begin(), out.scan_ms.end()));
  json.EndObject();
  json.Key("localized_scans").Value(out.localized);
  json.Key("localized_fraction").Value(LocalizedFraction(out));
  json.Key("matched_scans").Value(out.matched);
  json.Key("first_localized_scan").Value(out.first_localized);
  json.Key("lost_events").Value(out.lost_events).Key("recovered_events").Value(out.recovered_events);
  json.Key("rechecks").Value(out.rechecks);
  json.Key("field_tracked").Value(out.field_tracked);
  json.Key("status_counts").BeginObject();
  for (int s = 0; s < 4; ++s) {
    json.Key(ToString(static_cast<LocalizerStatus>(s))).Value(out.status_counts[s]);
  }
  json.EndObject();
  json.Key("odometry").BeginObject().Key("heading_per_m").Value(out.heading_per_m);
  json.Key("heading_per_rad").Value(out.heading_per_rad).EndObject();
  json.Key("log").BeginObject().Key("path").Value(reader.Path()).Key("format").Value(reader.Format());
  json.Key("skipped_records").Value(reader.Stats().skipped_records).EndObject();
  json.EndObject();
  return json.str() + "\n";
}

std::vector<LaserScan> ReadScans(io::LogReader& reader, long long max_scans) {
  std::vector<LaserScan> scans;
  while (std::optional<LaserScan> scan = reader.Next()) {
    if (max_scans >= 0 && static_cast<long long>(scans.size()) >= max_scans) break;
    scans.push_back(std::move(*scan));
  }
  return scans;
}

}  // namespace

int RunLocalize(const Args& args) {
  ArgParser parser = MakeParser();
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  LocalizerParams params = LoadLocalizerParamsForApp(parser.GetOptional("--config"));
  if (parser.Has("--no-odometry")) params.stages.use_odometry = false;
  const std::string map_path = parser.Get("MAP"), log = parser.Get("LOG");
  const std::string out_dir = parser.GetOptional("--out").value_or("shape-slam-localize");
  const bool quiet = parser.Has("--quiet");
  const long long max_scans = parser.Has("--max-scans") ? parser.GetIndex("--max-scans") : -1;
  std::optional<Pose2> initial;
  if (parser.Has("--initial")) {
    const std::vector<double> v = parser.GetDoubles("--initial");
    initial = Pose2(v[0], v[1], v[2]);
  }
  io::EnsureDirectory(out_dir);  // fail early on an unusable output path
  PolylineMap map = io::LoadMapFile(map_path);
  if (map.Empty()) throw std::runtime_error(map_path + ": the map has no polylines");

  const std::unique_ptr<io::LogReader> reader = OpenLogForApp(log, parser.Has("--strict"));
  const std::vector<LaserScan> scans = ReadScans(*reader, max_scans);
  ReportLogIssues(*reader);
  if (scans.empty()) throw std::runtime_error(log + ": no laser scans to localize");

  Localizer localizer(std::move(map), params);
  if (initial) localizer.SetInitialPose(*initial);
  SetFatalContext("localizing the log " + log.substr(0, 400));
  const LocalizeOutput out = RunLocalizer(localizer, scans, quiet);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  io::StagedFiles files;
  const auto stage = [&](const char* name, const std::string& content) {
    files.Stage((std::filesystem::path(out_dir) / name).string(), content);
  };
  stage("trajectory.tum", io::FormatTum(out.trajectory));
  {
    io::Drawing drawing = io::MakeMapDrawing(localizer.Map(), out.pieces,
                                             std::filesystem::path(log).filename().string());
    if (!out.lost_at.empty()) {
      drawing.layers.push_back({"lost", {}, out.lost_at, {240, 140, 0}, 1.0, 4.0, false});
    }
    stage("map.svg", io::RenderSvg(drawing));
    stage("map.png", io::RenderPng(drawing));
  }
  stage("status.csv", out.status_csv);
  stage("stats.json", StatsJson(out, map_path, *reader, initial.has_value(), wall_s));
  files.Commit();
  if (out.localized == 0) std::cerr << "warning: the robot was never localized in the map\n";
  if (!quiet) {
    std::cout << std::fixed << std::setprecision(2) << "localized " << out.localized << " of "
              << out.scans << " scans (" << 100.0 * LocalizedFraction(out) << " %), first at scan "
              << out.first_localized << ", lost " << out.lost_events << "x, recovered "
              << out.recovered_events << "x, median " << Percentile(out.scan_ms, 0.5)
              << " ms/scan\noutputs in " << out_dir
              << "/ (trajectory.tum, map.svg, map.png, status.csv, stats.json)\n";
  }
  return 0;
}

}  // namespace shape_slam::app
