// Micro-benchmarks of the alignment (§5.1) and its Ceres refinement on a synthetic room: a
// 30-segment model and a scan of 176 samples (10 cm spacing, 1 cm noise), started 0.3 m / 5 deg
// off. Run: build/bench/alignment_bench [--benchmark_format=csv]
//
// Medians on the development machine (2 shared cores at 2.6 GHz, Release, load ~2):
//   BM_AlignShapes                 76 us  (15 ICP iterations, 2.0 mm from the truth)
//   BM_RefineUnrestricted         224 us  (173 residuals, 1 outer iteration, 1.9 mm)
//   BM_RefineRestrictedWithPrior  220 us
//   BM_AlignThenRefine            311 us  (what the pipeline runs per scan)
// The remaining error is the noise's: the model is fit exactly on noise-free data.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "shape_slam/alignment.h"
#include "shape_slam/alignment_refinement.h"

namespace shape_slam {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A room with alcoves, a pillar and a door: 30 segments over 5 polylines, map frame.
std::vector<Polyline> Model() {
  return {
      {{-5.0, -3.0},
       {-2.0, -3.0},
       {-2.0, -3.5},
       {-1.0, -3.5},
       {-1.0, -3.0},
       {2.0, -3.0},
       {2.0, -3.4},
       {3.0, -3.4},
       {3.0, -3.0},
       {6.0, -3.0},
       {6.0, 0.0}},  // 10 segments
      {{6.0, 1.0},
       {6.0, 4.0},
       {3.0, 4.0},
       {3.0, 4.3},
       {2.2, 4.3},
       {2.2, 4.0},
       {-1.0, 4.0},
       {-1.0, 4.5},
       {-2.0, 4.5},
       {-2.0, 4.0},
       {-5.0, 4.0}},  // 10 segments
      {{-5.0, 4.0}, {-5.0, 1.5}, {-5.3, 1.5}, {-5.3, 0.5}, {-5.0, 0.5}, {-5.0, -3.0}},  // 5
      {{1.0, 0.8}, {1.0, 0.4}, {1.4, 0.4}},                                             // 2
      {{-2.5, 1.0}, {-2.5, 0.6}, {-2.1, 0.6}, {-2.1, 1.0}},                             // 3
  };
}

// Dense noisy perception of a subset of the model from T_map_scan, sampled like the pipeline.
struct Scene {
  std::vector<Polyline> model;
  std::vector<ShapePair> pairs;
  std::vector<Point2> samples_scan;
  Pose2 truth{0.4, 0.2, 0.3};
  Pose2 init{0.65, 0.0, 0.3 + 5.0 * kDeg};
};

Scene MakeScene() {
  Scene scene;
  scene.model = Model();
  std::mt19937 prng(42);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Pose2 T_scan_map = scene.truth.Inverse();
  for (const Polyline& polyline : scene.model) {
    Polyline perceived;
    for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
      const Point2 ab = polyline[i + 1] - polyline[i];
      const int n = std::max(1, static_cast<int>(std::ceil(ab.norm() / 0.1)));
      for (int k = 0; k < n; ++k) {
        perceived.push_back(T_scan_map * (polyline[i] + (static_cast<double>(k) / n) * ab) +
                            Point2(noise(prng), noise(prng)));
      }
    }
    perceived.push_back(T_scan_map * polyline.back());
    scene.pairs.push_back({perceived, {polyline}, 1.0});
  }
  // About 180 samples: the scan sees the right half of the room and the pillars.
  scene.pairs.erase(scene.pairs.begin() + 2);
  Polyline& bottom = scene.pairs[0].perceived;
  bottom.erase(bottom.begin(), bottom.begin() + 80);
  Polyline& top = scene.pairs[1].perceived;
  top.erase(top.end() - 100, top.end());
  for (const ShapePair& pair : scene.pairs) {
    for (const Point2& p : SamplePolyline(pair.perceived, 0.1)) scene.samples_scan.push_back(p);
  }
  return scene;
}

const Scene& TheScene() {
  static const Scene scene = MakeScene();
  return scene;
}

void BM_AlignShapes(benchmark::State& state) {
  const Scene& scene = TheScene();
  AlignmentResult result;
  for (auto _ : state) {
    result = AlignShapes(scene.pairs, scene.init, AlignmentParams{});
    benchmark::DoNotOptimize(result);
  }
  state.counters["samples"] = static_cast<double>(scene.samples_scan.size());
  state.counters["iterations"] = result.iterations;
  state.counters["error_mm"] =
      1e3 * std::hypot(result.T_map_scan.x - scene.truth.x, result.T_map_scan.y - scene.truth.y);
}
BENCHMARK(BM_AlignShapes)->Unit(benchmark::kMicrosecond);

void BM_RefineUnrestricted(benchmark::State& state) {
  const Scene& scene = TheScene();
  const AlignmentResult icp = AlignShapes(scene.pairs, scene.init, AlignmentParams{});
  RefinementResult result;
  for (auto _ : state) {
    result = RefineAlignment(scene.samples_scan, scene.model, icp.T_map_scan, std::nullopt);
    benchmark::DoNotOptimize(result);
  }
  state.counters["residuals"] = result.num_residuals;
  state.counters["outer_iterations"] = result.iterations;
  state.counters["error_mm"] =
      1e3 * std::hypot(result.T_map_scan.x - scene.truth.x, result.T_map_scan.y - scene.truth.y);
}
BENCHMARK(BM_RefineUnrestricted)->Unit(benchmark::kMicrosecond);

void BM_RefineRestrictedWithPrior(benchmark::State& state) {
  const Scene& scene = TheScene();
  const AlignmentResult icp = AlignShapes(scene.pairs, scene.init, AlignmentParams{});
  const PosePrior prior{scene.init, Eigen::Vector3d(0.1, 0.1, 0.01).asDiagonal()};
  RefinementResult result;
  for (auto _ : state) {
    result = RefineAlignment(scene.pairs, icp.T_map_scan, prior);
    benchmark::DoNotOptimize(result);
  }
  state.counters["residuals"] = result.num_residuals;
  state.counters["outer_iterations"] = result.iterations;
}
BENCHMARK(BM_RefineRestrictedWithPrior)->Unit(benchmark::kMicrosecond);

// What the pipeline runs per scan: the restricted ICP, then the unrestricted refinement.
void BM_AlignThenRefine(benchmark::State& state) {
  const Scene& scene = TheScene();
  RefinementResult result;
  for (auto _ : state) {
    const AlignmentResult icp = AlignShapes(scene.pairs, scene.init, AlignmentParams{});
    result = RefineAlignment(scene.samples_scan, scene.model, icp.T_map_scan, std::nullopt);
    benchmark::DoNotOptimize(result);
  }
  state.counters["error_mm"] =
      1e3 * std::hypot(result.T_map_scan.x - scene.truth.x, result.T_map_scan.y - scene.truth.y);
}
BENCHMARK(BM_AlignThenRefine)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace shape_slam
BENCHMARK_MAIN();
