// Micro-benchmarks of the shape toolkit (paper §3.1, §4.1): extraction + DCE of a 361-beam scan
// (a SICK-like 180 deg scan at 0.5 deg of a furnished room, 1 cm range noise), and S* of two
// 20-vertex polylines. Run: build/bench/shape_bench [--benchmark_repetitions=5]
// Figures measured are in docs/notebook.md (section "Micro-benchmarks").
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/shape_similarity.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

LaserScan Scan361() {
  testing::Scene scene = testing::OfficeRoom();
  testing::AddPillar(scene, {3.0, 2.6}, 0.1);
  scene.push_back({{1.0, 4.2}, {1.6, 4.6}});
  testing::ScannerModel model;
  model.beams = 361;
  std::mt19937 prng(1);
  return testing::SimulateScan(scene, Pose2(1.0, 1.2, 0.7), model, prng);
}

void BM_ExtractAndDce361(benchmark::State& state) {
  const LaserScan scan = Scan361();
  const ExtractionParams extraction;
  const double threshold = DceParams{}.threshold_m;
  std::size_t vertices = 0;
  for (auto _ : state) {
    vertices = 0;
    for (const Polyline& p : ExtractPolylines(scan, extraction)) {
      const Polyline s = SimplifyDce(p, threshold);
      vertices += s.size();
      benchmark::DoNotOptimize(s.data());
    }
  }
  state.counters["vertices"] = static_cast<double>(vertices);
}
BENCHMARK(BM_ExtractAndDce361)->Unit(benchmark::kMicrosecond);

// A 20-vertex polyline: an irregular wall outline with alcoves.
Polyline Outline20(double jitter, unsigned seed) {
  std::mt19937 prng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  Polyline p;
  for (int i = 0; i < 20; ++i) {
    const double x = 0.5 * i;
    const double y = (i % 4 == 1 || i % 4 == 2) ? 0.4 : 0.0;
    p.emplace_back(x + u(prng), y + (i % 7 == 3 ? 0.25 : 0.0) + u(prng));
  }
  return p;
}

void BM_EvolvedSimilarity20(benchmark::State& state) {
  const Polyline perceived = Outline20(0.03, 1);
  const Polyline model = Outline20(0.03, 2);
  double s = 0.0;
  for (auto _ : state) {
    s = ComputeEvolvedSimilarity(perceived, model).value;
    benchmark::DoNotOptimize(s);
  }
  state.counters["S*"] = s;
}
BENCHMARK(BM_EvolvedSimilarity20)->Unit(benchmark::kMicrosecond);

void BM_PolylineSimilarity20(benchmark::State& state) {
  const Polyline c = Outline20(0.03, 1);
  const Polyline d = Outline20(0.03, 2);
  for (auto _ : state) benchmark::DoNotOptimize(PolylineSimilarity(c, d).value);
}
BENCHMARK(BM_PolylineSimilarity20)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace shape_slam

BENCHMARK_MAIN();
