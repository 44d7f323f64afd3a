// Scan-pair matching benchmark (issue: shape matching without odometry). For consecutive and
// near-consecutive laser scans of logs with reference poses, it estimates the motion between
// the two scans with ShapeSLAM's MatchScans (scan_matcher.h) and with MRPT's CICP (classic,
// point maps of the same scans, the [ICP] options of MRPT's shipped icp-slam_demo_classic.ini),
// from (a) no guess (CICP: identity) and (b) guesses perturbed from the reference motion by
// 0.5 m / 10 deg, 1.0 m / 20 deg and 1.5 m / 30 deg (random direction and sign, fixed seed).
// Success: translation error < 5 cm and rotation error < 1 deg. A first condition starts both
// methods at the reference motion, which measures how accurate the reference itself is. Times include extraction from
// the raw scans (ShapeSLAM) and building the two point maps (MRPT), one thread.
//
// Usage: match_benchmark [--out DIR] [--max-pairs N] [LOG GT ...]
//   default logs: the development logs in datasets/radish; writes DIR/match.csv and match.md
//   (DIR default bench/results), prints the Markdown table.
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/slam/CICP.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>
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
constexpr double kSuccessTrans = 0.05;       // m
constexpr double kSuccessRot = 1.0 * kDeg;   // rad

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

std::string Stem(const std::string& path) {
  std::string name = path.substr(path.find_last_of('/') + 1);
  return name.substr(0, name.find('.'));
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
                   "comment at the top of bench/match_benchmark.cpp). Default: the development\n"
                   "logs; writes DIR/match.csv and DIR/match.md (DIR: bench/results).\n";
      return 0;
    } else if (a == "--out" && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (a == "--max-pairs" && i + 1 < argc) {
      max_pairs = std::stoul(argv[++i]);
    } else {
      inputs.push_back(a);
    }
  }
  if (inputs.empty()) {
    for (const char* log : {"intel", "aces", "freiburg-079"}) {
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
    const shape_slam::ScanMatchParams params;
    for (std::size_t f = 0; f < inputs.size(); f += 2) {
      const std::vector<LaserScan> scans = shape_slam::io::ReadAllScans(inputs[f]);
      std::vector<shape_slam::StampedPose> gt = shape_slam::io::ReadTrajectory(inputs[f + 1]);
      // Reference pose of each scan, by timestamp (1 ms tolerance).
      std::map<long long, Pose2> by_ms;
      for (const auto& s : gt) by_ms[std::llround(s.timestamp_s * 1000.0)] = s.pose;
      std::vector<std::pair<std::size_t, Pose2>> ref;
      for (std::size_t k = 0; k < scans.size(); ++k) {
        const auto it = by_ms.find(std::llround(scans[k].timestamp_s * 1000.0));
        if (it != by_ms.end()) ref.emplace_back(k, it->second);
      }
      std::cerr << Stem(inputs[f]) << ": " << scans.size() << " scans, " << ref.size()
                << " with reference poses\n";
      for (const int gap : {1, 3}) {
        std::vector<std::size_t> starts;
        const std::size_t n = ref.size() > static_cast<std::size_t>(gap) ? ref.size() - gap : 0;
        const std::size_t stride = std::max<std::size_t>(1, (n + max_pairs - 1) / max_pairs);
        for (std::size_t s = 0; s < n; s += stride) starts.push_back(s);
        std::mt19937 rng(12345 + gap);
        std::vector<Row> log_rows;
        for (const Condition& c : kConditions) {
          log_rows.push_back({Stem(inputs[f]), "ShapeSLAM", c.name, gap, {}});
          log_rows.push_back({Stem(inputs[f]), "MRPT CICP", c.name, gap, {}});
        }
        for (const std::size_t s : starts) {
          const LaserScan& a = scans[ref[s].first];
          const LaserScan& b = scans[ref[s + gap].first];
          const Pose2 truth = ref[s].second.Inverse() * ref[s + gap].second;
          for (std::size_t ci = 0; ci < kConditions.size(); ++ci) {
            const Condition& c = kConditions[ci];
            std::optional<Pose2> guess;
            Pose2 icp_guess;
            if (c.trans_m >= 0.0) {
              const double dir = std::uniform_real_distribution<double>(-M_PI, M_PI)(rng);
              const double sign = std::bernoulli_distribution(0.5)(rng) ? 1.0 : -1.0;
              guess = Pose2(truth.x + c.trans_m * std::cos(dir), truth.y + c.trans_m * std::sin(dir),
                            truth.theta + sign * c.rot_rad);
              icp_guess = *guess;
            }
            auto t0 = Clock::now();
            const shape_slam::ScanMatchResult m = shape_slam::MatchScans(a, b, guess, params);
            auto t1 = Clock::now();
            log_rows[2 * ci].outcomes.push_back(
                Error(m.T_i_j, truth, std::chrono::duration<double, std::milli>(t1 - t0).count()));
            t0 = Clock::now();
            const mrpt::maps::CSimplePointsMap map_a = PointsMap(a), map_b = PointsMap(b);
            mrpt::slam::CICP icp = MakeIcp();
            const mrpt::poses::CPosePDF::Ptr pdf = icp.Align(
                &map_a, &map_b, mrpt::poses::CPose2D(icp_guess.x, icp_guess.y, icp_guess.theta));
            t1 = Clock::now();
            const mrpt::poses::CPose2D mean = pdf->getMeanVal();
            log_rows[2 * ci + 1].outcomes.push_back(
                Error(Pose2(mean.x(), mean.y(), mean.phi()), truth,
                      std::chrono::duration<double, std::milli>(t1 - t0).count()));
          }
        }
        rows.insert(rows.end(), log_rows.begin(), log_rows.end());
        std::cerr << "  gap " << gap << ": " << starts.size() << " pairs done\n";
      }
    }
    std::ostringstream csv, md;
    csv << "log,gap,method,condition,pairs,success_pct,trans_err_median_m,trans_err_p90_m,"
           "rot_err_median_deg,rot_err_p90_deg,time_median_ms,time_p95_ms\n";
    md << "| log | pairs (gap) | guess | ShapeSLAM success | MRPT ICP success | ShapeSLAM median "
          "err (m / deg) | ICP median err (m / deg) | ShapeSLAM ms (median) | ICP ms (median) |\n"
          "|---|---|---|---|---|---|---|---|---|\n";
    std::map<std::string, std::vector<double>> line;
    for (std::size_t r = 0; r < rows.size(); r += 2) {
      std::vector<std::vector<double>> stats;
      for (const Row* row : {&rows[r], &rows[r + 1]}) {
        std::vector<double> te, re, ms;
        int ok = 0;
        for (const Outcome& o : row->outcomes) {
          te.push_back(o.trans_err);
          re.push_back(o.rot_err / kDeg);
          ms.push_back(o.ms);
          ok += o.success() ? 1 : 0;
        }
        const double pct = row->outcomes.empty() ? 0.0 : 100.0 * ok / row->outcomes.size();
        stats.push_back({pct, Percentile(te, 0.5), Percentile(re, 0.5), Percentile(ms, 0.5)});
        char buf[512];
        std::snprintf(buf, sizeof buf, "%s,%d,%s,%s,%zu,%.1f,%.4f,%.4f,%.3f,%.3f,%.3f,%.3f\n",
                      row->log.c_str(), row->gap, row->method.c_str(), row->condition.c_str(),
                      row->outcomes.size(), pct, Percentile(te, 0.5), Percentile(te, 0.9),
                      Percentile(re, 0.5), Percentile(re, 0.9), Percentile(ms, 0.5),
                      Percentile(ms, 0.95));
        csv << buf;
      }
      char buf[512];
      std::snprintf(buf, sizeof buf,
                    "| %s | %zu (%d) | %s | %.1f %% | %.1f %% | %.3f / %.2f | %.3f / %.2f | %.2f | "
                    "%.2f |\n",
                    rows[r].log.c_str(), rows[r].outcomes.size(), rows[r].gap,
                    rows[r].condition.c_str(), stats[0][0], stats[1][0], stats[0][1], stats[0][2],
                    stats[1][1], stats[1][2], stats[0][3], stats[1][3]);
      md << buf;
    }
    shape_slam::io::EnsureDirectory(out_dir);
    shape_slam::io::WriteFileAtomically(out_dir + "/match.csv", csv.str());
    shape_slam::io::WriteFileAtomically(out_dir + "/match.md", md.str());
    std::cout << md.str();
  } catch (const std::exception& e) {
    std::cerr << "match_benchmark: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
