// Synthetic scenes for the alignment tests and benchmark: model polylines in the map frame and a
// simulated perception of them (dense noisy points in the scan frame, as a laser delivers).
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "shape_slam/alignment.h"
#include "shape_slam/types.h"

namespace shape_slam::test {

/// An L-shaped corner: two walls meeting at (6, 3).
inline std::vector<Polyline> LCornerScene() { return {{{6.0, -2.0}, {6.0, 3.0}, {1.0, 3.0}}}; }

/// A room (open at a door in its lower-left corner) with a square pillar of which two faces are
/// seen.
inline std::vector<Polyline> RoomWithPillarScene() {
  return {{{-4.0, -2.2}, {-4.0, -3.0}, {5.0, -3.0}, {5.0, 4.0}, {-4.0, 4.0}, {-4.0, -1.2}},
          {{1.8, 1.2}, {1.8, 0.8}, {2.2, 0.8}}};
}

/// A 16 m corridor, 2 m wide, with door recesses (0.9 m wide, 0.25 m deep) in both walls: the
/// door jambs are all that constrains the pose along the corridor's axis (x).
inline std::vector<Polyline> CorridorWithDoorsScene() {
  return {{{-8.0, 1.0},
           {-5.0, 1.0},
           {-5.0, 1.25},
           {-4.1, 1.25},
           {-4.1, 1.0},
           {1.0, 1.0},
           {1.0, 1.25},
           {1.9, 1.25},
           {1.9, 1.0},
           {8.0, 1.0}},
          {{8.0, -1.0},
           {4.9, -1.0},
           {4.9, -1.25},
           {4.0, -1.25},
           {4.0, -1.0},
           {-1.1, -1.0},
           {-1.1, -1.25},
           {-2.0, -1.25},
           {-2.0, -1.0},
           {-8.0, -1.0}}};
}

/// Two straight parallel walls: nothing constrains the pose along x.
inline std::vector<Polyline> StraightCorridorScene() {
  return {{{-8.0, 1.0}, {8.0, 1.0}}, {{8.0, -1.0}, {-8.0, -1.0}}};
}

/// Points along a polyline every `step_m` (vertices included), like the returns of a laser.
inline Polyline Densify(const Polyline& polyline, double step_m) {
  Polyline out;
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    const Point2 ab = polyline[i + 1] - polyline[i];
    const int n = std::max(1, static_cast<int>(std::ceil(ab.norm() / step_m)));
    for (int k = 0; k < n; ++k) out.push_back(polyline[i] + (static_cast<double>(k) / n) * ab);
  }
  if (!polyline.empty()) out.push_back(polyline.back());
  return out;
}

/// The model polylines as perceived from T_map_scan: dense points (every 4 cm) in the scan frame
/// with isotropic Gaussian noise of `noise_m` per axis.
inline std::vector<Polyline> Perceive(const std::vector<Polyline>& model_map,
                                      const Pose2& T_map_scan, double noise_m, std::mt19937& prng) {
  std::normal_distribution<double> noise(0.0, noise_m);
  const Pose2 T_scan_map = T_map_scan.Inverse();
  std::vector<Polyline> perceived;
  for (const Polyline& polyline : model_map) {
    Polyline scan = Transform(T_scan_map, Densify(polyline, 0.04));
    for (Point2& p : scan) p += Point2(noise(prng), noise(prng));
    perceived.push_back(std::move(scan));
  }
  return perceived;
}

/// One pair per model polyline with its perception (correct correspondences).
inline std::vector<ShapePair> MakePairs(const std::vector<Polyline>& perceived_scan,
                                        const std::vector<Polyline>& model_map) {
  std::vector<ShapePair> pairs;
  for (std::size_t i = 0; i < model_map.size(); ++i) {
    pairs.push_back({perceived_scan[i], {model_map[i]}, 1.0});
  }
  return pairs;
}

/// A random start around `truth`: translation offset of uniform length in [0, max_m] in a
/// uniform direction, rotation offset uniform in [-max_rad, max_rad].
inline Pose2 Perturb(const Pose2& truth, double max_m, double max_rad, std::mt19937& prng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double r = max_m * unit(prng), phi = 2.0 * M_PI * unit(prng);
  const double dtheta = max_rad * (2.0 * unit(prng) - 1.0);
  return {truth.x + r * std::cos(phi), truth.y + r * std::sin(phi),
          NormalizeAngle(truth.theta + dtheta)};
}

}  // namespace shape_slam::test
