// shape-slam run: the incremental mapper over a whole log (paper §3-§5).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>
#ifdef __linux__
#include <malloc.h>  // malloc_trim (glibc)
#endif

#include "cli.h"
#include "commands.h"
#include "app_common.h"
#include "progress.h"
#include "shape_slam/localizer.h"
#include "shape_slam/pipeline.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/json_writer.h"
#include "shape_slam_io/map_file.h"
#include "shape_slam_io/occupancy_grid.h"
#include "shape_slam_io/ros_map.h"
#include "shape_slam_io/params_ini.h"
#include "shape_slam_io/trajectory_io.h"
#if SHAPE_SLAM_HAVE_MRPT
#include "shape_slam_io/mrpt_maps.h"
#endif

namespace shape_slam::app {
namespace {

constexpr const char* kDefaultLog =
    "/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog";

// run --map without --initial: the scans the global search may try before the run fails.
constexpr long long kDefaultSearchScans = 20;

ArgParser MakeParser() {
  ArgParser parser("run",
                   "Builds a polyline map from a laser log: per scan, polylines are extracted and\n"
                   "simplified, matched against the visible map shape, aligned, and merged into\n"
                   "the map (paper §3-§5). Without LOG it maps the MRPT sample log.");
  parser.Positional("LOG", "CARMEN log (.log/.clf[.gz]) or MRPT rawlog", false)
      .Option("--config", {"FILE.ini"}, "parameters (see config/default.ini for every key)")
      .Option("--out", {"DIR"}, "output directory", "./shape-slam-out")
      .Option("--map", {"MAP"}, "continue mapping from a saved map.polylines (kept and extended)")
      .Option("--initial", {"X", "Y", "THETA"},
              "with --map: the robot's first pose in MAP (m, m, rad); default: global search")
      .Option("--search-scans", {"N"},
              "with --map and no --initial: fail when none of the first N scans is localized",
              std::to_string(kDefaultSearchScans))
      .Flag("--no-odometry", "ignore the log's odometry: match by shape alone (paper §4.3)")
      .Option("--max-scans", {"N"}, "process only the first N laser scans")
      .Flag("--quiet", "no progress bar and no summary")
      .Flag("--print-config", "print the parameters in ini form (defaults, or --config's) and exit")
      .Flag("--strict", "fail on the first malformed log record instead of skipping it")
      .Option("--grid-resolution", {"M"}, "cell size of the occupancy grids, metres", "0.05")
      .Flag("--no-grid", "do not write map.pgm and map.yaml")
      .Flag("--no-gridmap", "do not write map.gridmap")
      .Flag("--no-simplemap", "do not write map.simplemap")
      .Epilog(
          "Outputs (written atomically into DIR, only after a successful run):\n"
          "  trajectory.tum   one line per laser scan: timestamp x y z qx qy qz qw (log time)\n"
          "  map.polylines    the map (format in include/shape_slam_io/map_file.h)\n"
          "  map.svg, map.png pictures of the map and the trajectory, 1 m grid\n"
          "  map.pgm, map.yaml  occupancy grid for ROS map_server (occupied 0, free 254,\n"
          "                   unknown 205): walls from the polylines, free space by ray casting\n"
          "                   the keyframe scans at their corrected poses\n"
          "  map.gridmap      the same grid as a gzip-compressed serialized MRPT\n"
          "                   COccupancyGridMap2D (MRPT builds only)\n"
          "  map.simplemap    the keyframe scans at their corrected poses, an MRPT CSimpleMap\n"
          "                   (observations2map, RawLogViewer; MRPT builds only)\n"
          "  stats.json       scans, wall time, per-scan times, map size, log issues\n"
          "  scan_times.csv   per laser scan: scan index, timestamp, processing time (ms), how it was\n"
          "                   placed (keyframe_track, fast_track, shape_match, unmatched), keyframe (1:\n"
          "                   it updated the map)\n"
          "  loops.csv        per loop closure found: the keyframes (index, timestamp), what\n"
          "                   became of it (agreed, taken, pending, confirmed, refused), the\n"
          "                   edge, the correction it asked, its fit both ways, the graph\n"
          "                   distance, whether it holds the heading and the offset across a\n"
          "                   corridor only and the corridor's direction (rad, old keyframe's\n"
          "                   frame) (bench/tools/loop_errors.py scores it)\n\n"
          "Continuing a map (--map MAP): MAP is loaded and is the starting map; the new scans\n"
          "extend it (its polylines are merged with what they see, as in mapping) and the\n"
          "output map holds both. The first scan is placed by the global search of 'shape-slam\n"
          "localize' (its [localizer] keys apply), and counts once the next scans confirm it\n"
          "(first_pose_confirm_scans): the scans before it are left out (noted on stderr and\n"
          "in stats.json, start_map.first_scan), and when none of the first --search-scans\n"
          "scans is localized the run fails (exit code 1). With --initial the first scan\n"
          "starts there. --out must not hold MAP itself.\n\n"
          "Examples:\n  shape-slam run datasets/radish/intel.log.gz --out intel-out\n"
          "  shape-slam run more.log --map intel-out/map.polylines --out intel-more");
  return parser;
}

struct RunOutput {
  std::size_t first_scan = 0;  // index in the log of the first scan mapped (run --map)
  std::vector<StampedPose> trajectory;
  std::vector<double> scan_ms;
  std::vector<const char*> scan_track;  // per scan: how it was placed (TrackName)
  std::vector<bool> scan_keyframe;      // per scan: it updated the map
  std::size_t matched = 0;
  int loop_closures = 0, loop_searches = 0, loop_closures_found = 0;
  int keyframes_in_map = 0;  // run --map: keyframes tied to the loaded map
  double processing_s = 0.0;
};

// How a scan was placed, as scan_times.csv names it.
const char* TrackName(const ScanReport& report) {
  if (report.keyframe_tracked) return "keyframe_track";
  if (report.fast_track) return "fast_track";
  return report.matched ? "shape_match" : "unmatched";
}

// Scans placed as `track` (a TrackName).
std::size_t CountTrack(const RunOutput& out, const std::string& track) {
  return static_cast<std::size_t>(std::count_if(out.scan_track.begin(), out.scan_track.end(),
                                                [&](const char* t) { return track == t; }));
}

// Maps the scans in order; each is released once processed (the mapper keeps what it needs of
// the keyframes), so that the log and the map it becomes are not both whole in memory.
RunOutput RunMapper(ShapeSlam& slam, std::vector<LaserScan>& scans, bool quiet) {
  RunOutput out;
  ProgressBar progress(scans.size(), "mapping", !quiet);
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const ScanReport report = slam.Process(scans[i]);
    const auto t1 = std::chrono::steady_clock::now();
    std::vector<double>().swap(scans[i].ranges_m);
    std::vector<double>().swap(scans[i].angles_rad);
    out.scan_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    out.trajectory.push_back({report.timestamp_s, report.T_map_robot});
    out.scan_track.push_back(TrackName(report));
    out.scan_keyframe.push_back(report.keyframe);
    out.matched += report.matched ? 1 : 0;
    progress.Update(i + 1);
  }
  progress.Finish();
  slam.Finish();  // final pose-graph optimisation
  out.trajectory = slam.Trajectory();  // corrected by the last pose-graph optimisation
  out.loop_closures = slam.NumLoopClosures();
  out.loop_searches = slam.NumLoopSearches();
  out.loop_closures_found = slam.NumLoopClosuresFound();
  out.keyframes_in_map = slam.NumKeyframesInLoadedMap();
  out.processing_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}


// run --map: the saved map, and where the log starts in it.
struct MapStart {
  std::string path;
  PolylineMap map;
  std::size_t polylines = 0;        // of the loaded map
  std::optional<Pose2> initial;     // --initial
  std::size_t search_scans = kDefaultSearchScans;
  FirstPose first;                  // the first scan mapped and its pose in the map
};

// The run must never destroy its input: an --out whose map.polylines is the file given to --map
// is refused.
void CheckOutputKeepsMap(const std::string& map_path, const std::string& out_dir) {
  namespace fs = std::filesystem;
  const fs::path target = fs::path(out_dir) / "map.polylines";
  std::error_code ec_equivalent, ec_map, ec_target;
  const bool equivalent = fs::equivalent(map_path, target, ec_equivalent);
  const fs::path map_canonical = fs::weakly_canonical(map_path, ec_map);
  const fs::path target_canonical = fs::weakly_canonical(target, ec_target);
  const bool same_path = !ec_map && !ec_target && map_canonical == target_canonical;
  if (equivalent || same_path) {
    throw UsageError("--out " + out_dir + " would overwrite the input map " + map_path +
                     " (its map.polylines): choose another output directory");
  }
}

std::optional<MapStart> ParseMapStart(const ArgParser& parser, const std::string& out_dir) {
  if (!parser.Has("--map")) {
    if (parser.Has("--initial") || parser.Has("--search-scans")) {
      throw UsageError("--initial and --search-scans need --map MAP");
    }
    return std::nullopt;
  }
  MapStart start;
  start.path = parser.Get("--map");
  CheckOutputKeepsMap(start.path, out_dir);
  if (parser.Has("--initial")) {
    const std::vector<double> v = parser.GetDoubles("--initial");
    start.initial = Pose2(v[0], v[1], v[2]);
  }
  if (parser.Has("--search-scans")) {
    start.search_scans = static_cast<std::size_t>(parser.GetIndex("--search-scans"));
    if (start.search_scans == 0) throw UsageError("--search-scans: must be at least 1");
  }
  start.map = io::LoadMapFile(start.path);  // errors name the file and line
  if (start.map.Empty()) throw std::runtime_error(start.path + ": the map has no polylines");
  start.polylines = start.map.NumPolylines();
  return start;
}

// Where the log starts in the map: --initial, or the first scan the global search of the
// localizer finds (localizer.h); the scans before it are left out.
void PlaceFirstScan(MapStart& start, const std::vector<LaserScan>& scans,
                    const LocalizerParams& params, const std::string& log) {
  if (start.initial) {
    start.first = {0, *start.initial};
    return;
  }
  SetFatalContext("localizing the first scans of " + log.substr(0, 400) + " in the map");
  const std::optional<FirstPose> first =
      LocalizeFirstScan(start.map, scans, start.search_scans, params);
  if (!first) {
    throw std::runtime_error(start.path + ": none of the first " +
                             std::to_string(std::min(start.search_scans, scans.size())) +
                             " scans of " + log +
                             " could be localized in the map (global search); give --initial "
                             "X Y THETA or a larger --search-scans");
  }
  start.first = *first;
  if (first->scan > 0) {
    std::cerr << "note: scans 0-" << first->scan - 1 << " were not localized in " << start.path
              << " and are left out; mapping starts at scan " << first->scan << "\n";
  }
}

void StartMapJson(io::JsonWriter& json, const MapStart& start, int keyframes_in_map) {
  json.Key("start_map").BeginObject().Key("path").Value(start.path);
  json.Key("polylines").Value(start.polylines);
  json.Key("initial_pose_given").Value(start.initial.has_value());
  json.Key("first_scan").Value(start.first.scan);
  json.Key("x").Value(start.first.T_map_robot.x).Key("y").Value(start.first.T_map_robot.y);
  json.Key("theta").Value(start.first.T_map_robot.theta);
  json.Key("keyframes_in_map").Value(keyframes_in_map).EndObject();
}

// Bytes of a 5 cm occupancy grid (1 byte per cell, MRPT's 8-bit cells) covering the map's
// bounding box: the representation the paper compares against.
std::size_t GridBytes(const PolylineMap& map, double resolution_m) {
  if (map.Empty()) return 0;
  Point2 min = Point2::Constant(std::numeric_limits<double>::infinity()), max = -min;
  for (const PolylineId id : map.Ids()) {
    for (const Point2& p : map.Get(id).points) min = min.cwiseMin(p), max = max.cwiseMax(p);
  }
  const Point2 size = max - min;
  return static_cast<std::size_t>(std::ceil(size.x() / resolution_m) + 1) *
         static_cast<std::size_t>(std::ceil(size.y() / resolution_m) + 1);
}

// A run in which fewer scans than this found a trusted match is reported with a warning: the
// map is likely inconsistent from where matching failed.
constexpr double kMinMatchedFraction = 0.9;

double MatchedFraction(const RunOutput& out) {
  return out.trajectory.empty() ? 0.0
                                : static_cast<double>(out.matched) / out.trajectory.size();
}

// What the user must know about the run on stderr: odometry that was not there, and a run in
// which matching failed too often to trust the map.
void ReportRunIssues(const RunOutput& out, const OdometryReport& odometry, bool requested) {
  if (requested && odometry.status == OdometryStatus::kAbsent) {
    std::cerr << "note: the log has no odometry: mapped by shape alone (as with --no-odometry)\n";
  } else if (requested && odometry.status == OdometryStatus::kConstant) {
    std::cerr << "note: the log's odometry never changes (" << odometry.scans_with_odometry
              << " scans, every pose equal to the first): treated as absent, mapped by shape "
                 "alone (as with --no-odometry)\n";
  } else if (requested && odometry.scans_predicted + 1 < odometry.scans) {
    std::cerr << "note: " << odometry.scans - odometry.scans_predicted - 1 << " of "
              << odometry.scans << " scans had no moving odometry";
    if (odometry.scans_stale > 0) {
      std::cerr << " (" << odometry.scans_stale
                << " while the robot moved: the odometry stalled, stats.json odometry.scans_stale)";
    }
    std::cerr << " and were matched by shape alone\n";
  }
  if (MatchedFraction(out) < kMinMatchedFraction) {
    std::cerr << std::fixed << std::setprecision(1) << "warning: only " << out.matched << " of "
              << out.trajectory.size() << " scans (" << 100.0 * MatchedFraction(out)
              << " %) found a trusted match; the map may be inconsistent where matching failed\n";
  }
}

// One line per laser scan: its index, its timestamp, the time ShapeSlam::Process took and how
// it was placed.
std::string FormatScanTimes(const RunOutput& out) {
  std::ostringstream csv;
  csv << "scan,timestamp_s,ms,track,keyframe\n" << std::fixed;
  const std::size_t n = std::min(out.scan_ms.size(), out.trajectory.size());
  for (std::size_t i = 0; i < n; ++i) {
    csv << out.first_scan + i << ',' << std::setprecision(6) << out.trajectory[i].timestamp_s << ','
        << std::setprecision(4) << out.scan_ms[i] << ',' << out.scan_track[i] << ','
        << (out.scan_keyframe[i] ? 1 : 0) << '\n';
  }
  return csv.str();
}

// Every loop closure found, what became of it (LoopDecision) and its numbers; keyframes by
// index and by their scans' timestamps (bench/tools/loop_errors.py scores them against
// reference poses).
std::string FormatLoops(const std::vector<LoopEvent>& events,
                        const std::vector<ShapeSlam::KeyframeView>& keyframes) {
  std::ostringstream csv;
  csv << "new_keyframe,old_keyframe,new_timestamp_s,old_timestamp_s,decision,edge_x_m,edge_y_m,"
         "edge_theta_rad,correction_m,correction_rad,inlier_ratio,reverse_inlier_ratio,"
         "graph_distance_m,across_only,along_rad\n"
      << std::fixed;
  const auto stamp = [&](int k) {
    return k >= 0 && k < static_cast<int>(keyframes.size()) ? keyframes[k].scan->timestamp_s : 0.0;
  };
  for (const LoopEvent& event : events) {
    const LoopClosure& c = event.closure;
    csv << c.new_keyframe << ',' << c.old_keyframe << ',' << std::setprecision(6)
        << stamp(c.new_keyframe) << ',' << stamp(c.old_keyframe) << ','
        << LoopDecisionName(event.decision) << ',' << c.edge.T_from_to.x << ','
        << c.edge.T_from_to.y << ',' << c.edge.T_from_to.theta << ','
        << c.correction.Translation().norm() << ',' << c.correction.theta << ','
        << std::setprecision(4) << c.inlier_ratio << ',' << c.reverse_inlier_ratio << ','
        << std::setprecision(2) << c.graph_distance_m << ',' << (c.across_only ? 1 : 0) << ','
        << std::setprecision(4) << c.along_rad << '\n';
  }
  return csv.str();
}

std::string StatsJson(const RunOutput& out, const PolylineMap& map, std::size_t map_file_bytes,
                      double wall_s, const io::LogReader& reader, const ShapeSlamParams& params,
                      const OdometryReport& odometry, const std::optional<MapStart>& start) {
  io::JsonWriter json;
  json.BeginObject().Key("scans").Value(out.trajectory.size());
  if (start) StartMapJson(json, *start, out.keyframes_in_map);
  json.Key("wall_s").Value(wall_s).Key("processing_s").Value(out.processing_s);
  double sum = 0.0;
  for (const double ms : out.scan_ms) sum += ms;
  json.Key("per_scan_ms").BeginObject();
  json.Key("median").Value(Percentile(out.scan_ms, 0.5)).Key("p95").Value(Percentile(out.scan_ms, 0.95));
  json.Key("max").Value(out.scan_ms.empty() ? 0.0 : *std::max_element(out.scan_ms.begin(), out.scan_ms.end()));
  json.Key("mean").Value(out.scan_ms.empty() ? 0.0 : sum / out.scan_ms.size());
  // Medians over the first and the last tenth of the log: whether the time grows with the map.
  const std::size_t tenth = out.scan_ms.size() / 10;
  json.Key("first_tenth_median")
      .Value(Percentile({out.scan_ms.begin(), out.scan_ms.begin() + tenth}, 0.5));
  json.Key("last_tenth_median")
      .Value(Percentile({out.scan_ms.end() - tenth, out.scan_ms.end()}, 0.5))
      .EndObject();
  const auto keyframes = static_cast<std::size_t>(
      std::count(out.scan_keyframe.begin(), out.scan_keyframe.end(), true));
  json.Key("matched_scans").Value(out.matched).Key("keyframes").Value(keyframes);
  json.Key("fast_tracked_scans").Value(CountTrack(out, "fast_track"));
  json.Key("keyframe_tracked_scans").Value(CountTrack(out, "keyframe_track"));
  json.Key("matched_fraction").Value(MatchedFraction(out));
  json.Key("low_match_warning").Value(MatchedFraction(out) < kMinMatchedFraction);
  json.Key("loop_closures").Value(out.loop_closures);
  json.Key("loop_searches").Value(out.loop_searches);
  json.Key("loop_closures_found").Value(out.loop_closures_found);
  json.Key("odometry").BeginObject().Key("requested").Value(params.use_odometry);
  json.Key("status").Value(ToString(odometry.status));
  json.Key("scans_with_odometry").Value(odometry.scans_with_odometry);
  json.Key("scans_predicted").Value(odometry.scans_predicted);
  json.Key("scans_stale").Value(odometry.scans_stale);
  json.Key("noise_scale_xy").Value(odometry.noise_scale_xy);
  json.Key("noise_scale_theta").Value(odometry.noise_scale_theta);
  json.Key("heading_per_m").Value(odometry.heading_per_m);
  json.Key("heading_per_rad").Value(odometry.heading_per_rad).EndObject();
  json.Key("map").BeginObject();
  json.Key("polylines").Value(map.NumPolylines()).Key("vertices").Value(map.NumVertices());
  json.Key("bytes").Value(map_file_bytes).Key("memory_bytes").Value(map.GeometryBytes());
  json.Key("grid_5cm_bytes").Value(GridBytes(map, 0.05)).EndObject();
  const io::LogReaderStats& stats = reader.Stats();
  json.Key("log").BeginObject().Key("path").Value(reader.Path()).Key("format").Value(reader.Format());
  json.Key("skipped_records").Value(stats.skipped_records);
  json.Key("invalid_ranges").Value(stats.invalid_ranges);
  json.Key("non_monotonic_timestamps").Value(stats.non_monotonic_timestamps).EndObject();
  json.EndObject();
  return json.str() + "\n";
}

// Memory freed (in the middle of the heap as well) goes back to the system, so that what is
// allocated next (a grid of tens of MB is a fresh mapping) does not add to it in the peak.
void ReturnFreedMemory() {
#if defined(__linux__) && defined(__GLIBC__)
  ::malloc_trim(0);
#endif
}

/// Which grid outputs to write, and their cell size.
struct GridOutputs {
  bool ros = true;        // map.pgm + map.yaml
  bool gridmap = true;    // map.gridmap (MRPT)
  bool simplemap = true;  // map.simplemap (MRPT)
  double resolution_m = 0.05;
};

// The occupancy grids, from the map's polylines and the keyframes at their final corrected poses
// (after the last pose-graph optimisation), each staged as soon as it is rendered:
// stage(name, content) for a content held whole, stage_stream(name, write) for one written
// piece by piece (returns the temporary file). A large map's grid is tens of MB, so it is held
// once at a time and alone: the map and the keyframes are released once the grid is made,
// map.pgm is written row by row from it, and map.gridmap is made from map.pgm read back once
// the grid is released too.
template <typename Stage, typename StageStream>
void StageGridOutputs(ShapeSlam::Result result, const GridOutputs& what, const Stage& stage,
                      const StageStream& stage_stream) {
  if (!what.ros && !what.gridmap) return;
  io::OccupancyGridParams params;
  params.resolution_m = what.resolution_m;
  io::OccupancyGrid grid;
  {
    const std::vector<Polyline> walls = result.map.Polylines();  // let go of once the grid is made
    result.map = PolylineMap();  // its spatial index weighs more than its polylines
    ReturnFreedMemory();
    grid = io::BuildOccupancyGrid(walls, result.KeyframeViews(), params);
  }
  result = ShapeSlam::Result();
  ReturnFreedMemory();
  std::string pgm_staged;
  if (what.ros) {
    pgm_staged = stage_stream("map.pgm", [&](const io::ByteWriter& w) { io::WritePgm(grid, w); });
    stage("map.yaml", io::FormatMapYaml(grid, "map.pgm"));
  }
#if SHAPE_SLAM_HAVE_MRPT
  if (what.gridmap && what.ros) {
    io::OccupancyGrid frame = std::move(grid);
    std::vector<io::CellState>().swap(frame.cells);  // released: read back from map.pgm
    stage("map.gridmap", io::FormatMrptGridmap(frame, pgm_staged));
  } else if (what.gridmap) {
    stage("map.gridmap", io::FormatMrptGridmap(std::move(grid)));
  }
#endif
}

// Every file is written to a temporary file as soon as it is rendered (so that only one
// rendering is in memory at a time: the grids of a large map are tens of MB), and all replace
// their targets only once every one is written: a failure leaves the directory as it was.
// The result is released as the outputs that need it are made (the grids last). Returns the
// names written, in order.
std::vector<std::string> WriteOutputs(const std::string& dir, const RunOutput& out,
                                      ShapeSlam::Result result, const GridOutputs& grids,
                                      const std::string& stats_json, std::string map_text,
                                      const std::string& title) {
  io::StagedFiles files;
  std::vector<std::string> names;
  const auto stage = [&](const std::string& name, const std::string& content) {
    files.Stage((std::filesystem::path(dir) / name).string(), content);
    names.push_back(name);
  };
  const auto stage_stream = [&](const std::string& name,
                                const std::function<void(const io::ByteWriter&)>& write) {
    std::string staged = files.Stage((std::filesystem::path(dir) / name).string(), write);
    names.push_back(name);
    return staged;
  };
  stage("trajectory.tum", io::FormatTum(out.trajectory));
  stage("map.polylines", map_text);
  std::string().swap(map_text);  // staged: not held while the grids are made
  {
    std::vector<Point2> path;
    for (const StampedPose& p : out.trajectory) path.push_back(p.pose.Translation());
    const io::Drawing drawing = io::MakeMapDrawing(result.map, path, title);
    stage("map.svg", io::RenderSvg(drawing));
    stage("map.png", io::RenderPng(drawing));
  }
  {
    // Every keyframe's scan at its final pose (views, not copies).
    const std::vector<ShapeSlam::KeyframeView> keyframes = result.KeyframeViews();
#if SHAPE_SLAM_HAVE_MRPT
    if (grids.simplemap) stage("map.simplemap", io::FormatMrptSimplemap(keyframes));
#endif
    stage("loops.csv", FormatLoops(result.loop_events, keyframes));
  }
  stage("scan_times.csv", FormatScanTimes(out));
  StageGridOutputs(std::move(result), grids, stage, stage_stream);
  stage("stats.json", stats_json);
  files.Commit();
  return names;
}

}  // namespace

int RunRun(const Args& args) {
  ArgParser parser = MakeParser();
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  LocalizerParams config = LoadLocalizerParamsForApp(parser.GetOptional("--config"));
  if (parser.Has("--no-odometry")) config.stages.use_odometry = false;
  const ShapeSlamParams& params = config.stages;
  if (parser.Has("--print-config")) {
    std::cout << io::FormatParamsIni(config);
    return 0;
  }
  const std::string log = parser.GetOptional("LOG").value_or(kDefaultLog);
  const std::string out_dir = parser.GetOptional("--out").value_or("shape-slam-out");
  const bool quiet = parser.Has("--quiet");
  const long long max_scans = parser.Has("--max-scans") ? parser.GetIndex("--max-scans") : -1;
  GridOutputs grids;
  grids.ros = !parser.Has("--no-grid");
  grids.gridmap = !parser.Has("--no-gridmap");
  grids.simplemap = !parser.Has("--no-simplemap");
  grids.resolution_m = parser.GetDouble("--grid-resolution", grids.resolution_m);
  if (grids.resolution_m <= 0.0) {
    throw UsageError("--grid-resolution: '" + parser.Get("--grid-resolution") +
                     "' is not a cell size > 0 (metres)");
  }
  std::optional<MapStart> start = ParseMapStart(parser, out_dir);
  io::EnsureDirectory(out_dir);  // fail early on an unusable output path

  const std::unique_ptr<io::LogReader> reader = OpenLogForApp(log, parser.Has("--strict"));
  std::vector<LaserScan> scans;
  while (std::optional<LaserScan> scan = reader->Next()) {
    if (max_scans >= 0 && static_cast<long long>(scans.size()) >= max_scans) break;
    scans.push_back(std::move(*scan));
  }
  ReportLogIssues(*reader);
  if (scans.empty()) throw std::runtime_error(log + ": no laser scans to map");

  std::unique_ptr<ShapeSlam> mapper;
  if (start) {
    PlaceFirstScan(*start, scans, config, log);
    mapper = std::make_unique<ShapeSlam>(params, start->map, start->first.T_map_robot);
    scans.erase(scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(start->first.scan));
  } else {
    mapper = std::make_unique<ShapeSlam>(params);
  }
  SetFatalContext("mapping the log " + log.substr(0, 400));
  RunOutput out = RunMapper(*mapper, scans, quiet);
  out.first_scan = start ? start->first.scan : 0;
  std::vector<LaserScan>().swap(scans);  // the keyframes keep what the outputs need
  // The outputs need the map and the keyframes, not the mapping state (submaps, shapes, graph).
  ShapeSlam::Result result = std::move(*mapper).TakeResult();
  mapper.reset();
  ReturnFreedMemory();  // what mapping freed, before the outputs are made
  std::string map_text = io::FormatMapFile(result.map);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  const std::string stats = StatsJson(out, result.map, map_text.size(), wall_s, *reader, params,
                                      result.odometry, start);
  const OdometryReport odometry = result.odometry;
  const std::size_t polylines = result.map.NumPolylines(), vertices = result.map.NumVertices();
  const std::vector<std::string> written = WriteOutputs(
      out_dir, out, std::move(result), grids, stats, std::move(map_text),
      std::filesystem::path(log).filename().string());
  ReportRunIssues(out, odometry, params.use_odometry);
  if (!quiet && start) {
    std::cout << std::fixed << std::setprecision(2) << "continued the map " << start->path << " ("
              << start->polylines << " polylines) from scan " << start->first.scan << " at ("
              << start->first.T_map_robot.x << ", " << start->first.T_map_robot.y << ", "
              << start->first.T_map_robot.theta << ")\n";
  }
  if (!quiet) {
    std::cout << std::fixed << std::setprecision(2) << "mapped " << out.trajectory.size()
              << " scans in " << out.processing_s << " s (median "
              << Percentile(out.scan_ms, 0.5) << " ms/scan), " << out.matched
              << " matched, map: " << polylines << " polylines, " << vertices << " vertices\n"
              << "outputs in " << out_dir << "/ (";
    for (std::size_t i = 0; i < written.size(); ++i) std::cout << (i ? ", " : "") << written[i];
    std::cout << ")\n";
  }
  return 0;
}

}  // namespace shape_slam::app
