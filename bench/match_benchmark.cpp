// Scan-pair matching benchmark (issue: shape matching without odometry). For consecutive and
// near-consecutive laser scans of logs with reference poses, it estimates the motion between
// the two scans with ShapeSLAM's MatchScans (scan_matcher.h) and with MRPT's CICP (classic,
// point maps of the same scans, the [ICP] options of MRPT's shipped icp-slam_demo_classic.ini),
// from (a) no guess (CICP: identity) and (b) guesses perturbed from the reference motion by
// 0.5 m / 10 deg, 1.0 m / 20 deg and 1.5 m / 30 deg (random direction and sign, fixed seed).
// Success: translation error < 10 cm and rotation error < 2 deg (the reference poses are only
// about 5 cm accurate). A first condition starts both methods at the reference motion: its
// success rate is the ceiling that the reference's own accuracy allows, and the summary gives
// no-guess success / ceiling per log and gap (pairs 1 and 2 scans apart). Times include
// extraction from the raw scans (ShapeSLAM) and building the two point maps (MRPT), one thread.
//
// Usage: match_benchmark [--out DIR] [--max-pairs N] [LOG GT ...]
//   default logs: the four development logs in datasets/radish; writes DIR/match.csv,
//   DIR/match.md and DIR/match_pairs.csv (the pairs, for bench/karto_pairs.py)
//   (DIR default bench/results), prints the Markdown tables.
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/slam/CICP.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "shape_slam/evaluation.h"
#include "shape_slam/scan_matcher.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/log_reader.h"
#include "shape_slam_io/trajectory_io.h"

namespace {

using shape_slam::LaserScan;
using shape_slam::Pose2;
using Clock = std::chrono::steady_clock;

constexpr double kDeg = M_PI / 180.0;
constexpr double kSuccessTrans = 0.10;       // m
constexpr double kSuccessRot = 2.0 * kDeg;   // rad
constexpr int kGaps[] = {1, 2};              // scans apart (in the reference's order)

struct Condition {
  std::string name;
  double trans_m;   // guess perturbation; < 0: no guess
  double rot_rad;
};

// "at the reference" starts both methods at the reference motion itself: its success rate is
// the ceiling that the reference poses' own accuracy allows (they come from an RBPF run, not a
// motion-capture system), against which the other rows should be read.
const std::vector<Condition> kConditions = {
    {"at the reference", 0.0, 0.0},
    {"no guess", -1.0, 0.0},
    {"0.5 m / 10 deg", 0.5, 10 * kDeg},
    {"1.0 m / 20 deg", 1.0, 20 * kDeg},
    {"1.5 m / 30 deg", 1.5, 30 * kDeg},
};

struct Outcome {
  double trans_err = 0.0, rot_err = 0.0, ms = 0.0;
  bool success() const { return trans_err < kSuccessTrans && rot_err < kSuccessRot; }
};

mrpt::maps::CSimplePointsMap PointsMap(const LaserScan& scan) {
  mrpt::maps::CSimplePointsMap map;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    const double r = scan.ranges_m[i];
    if (!std::isfinite(r) || r <= 0.0 || r >= scan.max_range_m) continue;
    const shape_slam::Point2 p =
        scan.T_robot_sensor * shape_slam::Point2(r * std::cos(scan.angles_rad[i]),
                                                 r * std::sin(scan.angles_rad[i]));
    map.insertPoint(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
  }
  return map;
}

mrpt::slam::CICP MakeIcp() {
  // [ICP] of /usr/share/mrpt/config_files/icp-slam/icp-slam_demo_classic.ini.
  mrpt::slam::CICP icp;
  icp.options.ICP_algorithm = mrpt::slam::icpClassic;
  icp.options.maxIterations = 80;
  icp.options.minAbsStep_trans = 1e-6;
  icp.options.minAbsStep_rot = 1e-6;
  icp.options.thresholdDist = 0.3;
  icp.options.thresholdAng = 5 * kDeg;
  icp.options.ALFA = 0.8;
  icp.options.smallestThresholdDist = 0.05;
  icp.options.onlyUniqueRobust = true;
  icp.options.corresponding_points_decimation = 5;
  return icp;
}

Outcome Error(const Pose2& estimate, const Pose2& truth, double ms) {
  const Pose2 d = truth.Inverse() * estimate;
  return {d.Translation().norm(), std::abs(shape_slam::NormalizeAngle(d.theta)), ms};
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, q * (v.size() - 1) + 0.5))];
}

struct Row {
  std::string log, method, condition;
  int gap = 1;
  std::vector<Outcome> outcomes;
};

// One scan pair: indices into the log's scans, their timestamps and the reference motion.
struct Pair {
  std::size_t a = 0, b = 0;
  double t_a = 0.0, t_b = 0.0;
  Pose2 T_a_b;
};

std::string Stem(const std::string& path) {
  std::string name = path.substr(path.find_last_of('/') + 1);
  return name.substr(0, name.find('.'));
}

// (scan index, reference pose) of every scan with a reference pose (by timestamp, 1 ms).
std::vector<std::pair<std::size_t, Pose2>> ReferencedScans(
    const std::vector<LaserScan>& scans, const std::vector<shape_slam::StampedPose>& gt) {
  std::map<long long, Pose2> by_ms;
  for (const auto& s : gt) by_ms[std::llround(s.timestamp_s * 1000.0)] = s.pose;
  std::vector<std::pair<std::size_t, Pose2>> ref;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const auto it = by_ms.find(std::llround(scans[k].timestamp_s * 1000.0));
    if (it != by_ms.end()) ref.emplace_back(k, it->second);
  }
  return ref;
}

// At most max_pairs pairs `gap` referenced scans apart, evenly spread over the log.
std::vector<Pair> SelectPairs(const std::vector<LaserScan>& scans,
                              const std::vector<std::pair<std::size_t, Pose2>>& ref, int gap,
                              std::size_t max_pairs) {
  const std::size_t n = ref.size() > static_cast<std::size_t>(gap) ? ref.size() - gap : 0;
  const std::size_t stride = std::max<std::size_t>(1, (n + max_pairs - 1) / max_pairs);
  std::vector<Pair> pairs;
  for (std::size_t s = 0; s < n; s += stride) {
    const auto& [a, pose_a] = ref[s];
    const auto& [b, pose_b] = ref[s + gap];
    pairs.push_back({a, b, scans[a].timestamp_s, scans[b].timestamp_s, pose_a.Inverse() * pose_b});
  }
  return pairs;
}

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Both methods on one pair from one condition's guess: (ShapeSLAM, MRPT CICP) outcomes.
std::pair<Outcome, Outcome> MatchPair(const LaserScan& a, const LaserScan& b, const Pose2& truth,
                                      const Condition& c, std::mt19937& rng,
                                      const shape_slam::ScanMatchParams& params) {
  std::optional<Pose2> guess;
  Pose2 icp_guess;  // CICP needs a guess: identity when there is none
  if (c.trans_m >= 0.0) {
    const double dir = std::uniform_real_distribution<double>(-M_PI, M_PI)(rng);
    const double sign = std::bernoulli_distribution(0.5)(rng) ? 1.0 : -1.0;
    guess = Pose2(truth.x + c.trans_m * std::cos(dir), truth.y + c.trans_m * std::sin(dir),
                  truth.theta + sign * c.rot_rad);
    icp_guess = *guess;
  }
  Clock::time_point t0 = Clock::now();
  const shape_slam::ScanMatchResult m = shape_slam::MatchScans(a, b, guess, params);
  const Outcome shape = Error(m.T_i_j, truth, MsSince(t0));
  t0 = Clock::now();
  const mrpt::maps::CSimplePointsMap map_a = PointsMap(a), map_b = PointsMap(b);
  mrpt::slam::CICP icp = MakeIcp();
  const mrpt::poses::CPosePDF::Ptr pdf = icp.Align(
      &map_a, &map_b, mrpt::poses::CPose2D(icp_guess.x, icp_guess.y, icp_guess.theta));
  const double icp_ms = MsSince(t0);
  const mrpt::poses::CPose2D mean = pdf->getMeanVal();
  return {shape, Error(Pose2(mean.x(), mean.y(), mean.phi()), truth, icp_ms)};
}

// Rows (ShapeSLAM, CICP) per condition for the pairs of one log and gap.
std::vector<Row> RunPairs(const std::string& log, int gap, const std::vector<LaserScan>& scans,
                          const std::vector<Pair>& pairs,
                          const shape_slam::ScanMatchParams& params) {
  std::mt19937 rng(12345 + gap);
  std::vector<Row> rows;
  for (const Condition& c : kConditions) {
    rows.push_back({log, "ShapeSLAM", c.name, gap, {}});
    rows.push_back({log, "MRPT CICP", c.name, gap, {}});
  }
  for (const Pair& p : pairs) {
    for (std::size_t ci = 0; ci < kConditions.size(); ++ci) {
      const auto [shape, icp] = MatchPair(scans[p.a], scans[p.b], p.T_a_b, kConditions[ci], rng,
                                          params);
      rows[2 * ci].outcomes.push_back(shape);
      rows[2 * ci + 1].outcomes.push_back(icp);
    }
  }
  return rows;
}

struct Stats {
  double success_pct = 0.0, trans_median = 0.0, trans_p90 = 0.0, rot_median_deg = 0.0,
         rot_p90_deg = 0.0, ms_median = 0.0, ms_p95 = 0.0;
};

Stats StatsOf(const Row& row) {
  std::vector<double> te, re, ms;
  int ok = 0;
  for (const Outcome& o : row.outcomes) {
    te.push_back(o.trans_err);
    re.push_back(o.rot_err / kDeg);
    ms.push_back(o.ms);
    ok += o.success() ? 1 : 0;
  }
  const double pct = row.outcomes.empty() ? 0.0 : 100.0 * ok / row.outcomes.size();
  return {pct,
          Percentile(te, 0.5),
          Percentile(te, 0.9),
          Percentile(re, 0.5),
          Percentile(re, 0.9),
          Percentile(ms, 0.5),
          Percentile(ms, 0.95)};
}

template <typename... Values>
std::string Format(const char* format, Values... values) {
  char buf[512];
  std::snprintf(buf, sizeof buf, format, values...);
  return buf;
}

// rows: (ShapeSLAM, CICP) pairs per condition, conditions in kConditions order per log and gap.
std::string CsvTable(const std::vector<Row>& rows) {
  std::string csv =
      "log,gap,method,condition,pairs,success_pct,trans_err_median_m,trans_err_p90_m,"
      "rot_err_median_deg,rot_err_p90_deg,time_median_ms,time_p95_ms\n";
  for (const Row& row : rows) {
    const Stats s = StatsOf(row);
    csv += Format("%s,%d,%s,%s,%zu,%.1f,%.4f,%.4f,%.3f,%.3f,%.3f,%.3f\n", row.log.c_str(), row.gap,
                  row.method.c_str(), row.condition.c_str(), row.outcomes.size(), s.success_pct,
                  s.trans_median, s.trans_p90, s.rot_median_deg, s.rot_p90_deg, s.ms_median,
                  s.ms_p95);
  }
  return csv;
}

std::string Ratio(double no_guess_pct, double ceiling_pct) {
  return ceiling_pct > 0.0 ? Format("%.2f", no_guess_pct / ceiling_pct) : std::string("–");
}

// Per log and gap: ceiling (at the reference), no guess, and their ratio, for both methods.
std::string SummaryTable(const std::vector<Row>& rows) {
  std::string md =
      "| log | gap | pairs | ShapeSLAM ceiling | ShapeSLAM no guess | ShapeSLAM ratio | "
      "ICP ceiling | ICP no guess | ICP ratio |\n|---|---|---|---|---|---|---|---|---|\n";
  const std::size_t per_block = 2 * kConditions.size();
  for (std::size_t r = 0; r + per_block <= rows.size(); r += per_block) {
    const Stats shape_ceiling = StatsOf(rows[r]), icp_ceiling = StatsOf(rows[r + 1]);
    const Stats shape_none = StatsOf(rows[r + 2]), icp_none = StatsOf(rows[r + 3]);
    md += Format("| %s | %d | %zu | %.1f %% | %.1f %% | %s | %.1f %% | %.1f %% | %s |\n",
                 rows[r].log.c_str(), rows[r].gap, rows[r].outcomes.size(),
                 shape_ceiling.success_pct, shape_none.success_pct,
                 Ratio(shape_none.success_pct, shape_ceiling.success_pct).c_str(),
                 icp_ceiling.success_pct, icp_none.success_pct,
                 Ratio(icp_none.success_pct, icp_ceiling.success_pct).c_str());
  }
  return md;
}

std::string DetailTable(const std::vector<Row>& rows) {
  std::string md =
      "| log | pairs (gap) | guess | ShapeSLAM success | MRPT ICP success | ShapeSLAM median "
      "err (m / deg) | ICP median err (m / deg) | ShapeSLAM ms (median) | ICP ms (median) |\n"
      "|---|---|---|---|---|---|---|---|---|\n";
  for (std::size_t r = 0; r + 1 < rows.size(); r += 2) {
    const Stats shape = StatsOf(rows[r]), icp = StatsOf(rows[r + 1]);
    md += Format("| %s | %zu (%d) | %s | %.1f %% | %.1f %% | %.3f / %.2f | %.3f / %.2f | %.2f | "
                 "%.2f |\n",
                 rows[r].log.c_str(), rows[r].outcomes.size(), rows[r].gap,
                 rows[r].condition.c_str(), shape.success_pct, icp.success_pct,
                 shape.trans_median, shape.rot_median_deg, icp.trans_median, icp.rot_median_deg,
                 shape.ms_median, icp.ms_median);
  }
  return md;
}

std::string PairsCsvHeader() {
  return "log,gap,scan_a,scan_b,t_a,t_b,ref_x_m,ref_y_m,ref_theta_rad\n";
}

std::string PairsCsv(const std::string& log, int gap, const std::vector<Pair>& pairs) {
  std::string csv;
  for (const Pair& p : pairs) {
    csv += Format("%s,%d,%zu,%zu,%.6f,%.6f,%.6f,%.6f,%.6f\n", log.c_str(), gap, p.a, p.b, p.t_a,
                  p.t_b, p.T_a_b.x, p.T_a_b.y, p.T_a_b.theta);
  }
  return csv;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir = "bench/results";
  std::size_t max_pairs = 600;
  std::vector<std::string> inputs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "Usage: match_benchmark [--out DIR] [--max-pairs N] [LOG GT ...]\n"
                   "Scan-pair matching, ShapeSLAM vs MRPT CICP, against reference poses (see the\n"
                   "comment at the top of bench/match_benchmark.cpp). Default: the four\n"
                   "development logs; writes DIR/match.csv, DIR/match.md and DIR/match_pairs.csv\n"
                   "(DIR: bench/results). N: pairs per log and gap (default 600).\n";
      return 0;
    } else if (a == "--out" && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (a == "--max-pairs" && i + 1 < argc) {
      max_pairs = std::max<std::size_t>(1, std::stoul(argv[++i]));
    } else {
      inputs.push_back(a);
    }
  }
  if (inputs.empty()) {
    for (const char* log : {"intel", "aces", "freiburg-079", "infinite-corridor"}) {
      inputs.push_back(std::string(SHAPE_SLAM_DATASETS_DIR) + "/radish/" + log + ".log.gz");
      inputs.push_back(std::string(SHAPE_SLAM_DATASETS_DIR) + "/radish/" + log + ".gt.txt");
    }
  }
  if (inputs.size() % 2 != 0) {
    std::cerr << "match_benchmark: expected LOG GT pairs\n";
    return 2;
  }
  try {
    std::vector<Row> rows;
    std::string pairs_csv = PairsCsvHeader();
    const shape_slam::ScanMatchParams params;
    for (std::size_t f = 0; f < inputs.size(); f += 2) {
      const std::string log = Stem(inputs[f]);
      const std::vector<LaserScan> scans = shape_slam::io::ReadAllScans(inputs[f]);
      const auto ref = ReferencedScans(scans, shape_slam::io::ReadTrajectory(inputs[f + 1]));
      std::cerr << log << ": " << scans.size() << " scans, " << ref.size()
                << " with reference poses\n";
      for (const int gap : kGaps) {
        const std::vector<Pair> pairs = SelectPairs(scans, ref, gap, max_pairs);
        const std::vector<Row> log_rows = RunPairs(log, gap, scans, pairs, params);
        rows.insert(rows.end(), log_rows.begin(), log_rows.end());
        pairs_csv += PairsCsv(log, gap, pairs);
        std::cerr << "  gap " << gap << ": " << pairs.size() << " pairs done\n";
      }
    }
    const std::string md = "Success: error < 10 cm and < 2 deg. Ceiling: started at the "
                           "reference motion. Ratio: no guess / ceiling.\n\n" +
                           SummaryTable(rows) + "\n" + DetailTable(rows);
    shape_slam::io::EnsureDirectory(out_dir);
    shape_slam::io::WriteFileAtomically(out_dir + "/match.csv", CsvTable(rows));
    shape_slam::io::WriteFileAtomically(out_dir + "/match.md", md);
    shape_slam::io::WriteFileAtomically(out_dir + "/match_pairs.csv", pairs_csv);
    std::cout << md;
  } catch (const std::exception& e) {
    std::cerr << "match_benchmark: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
