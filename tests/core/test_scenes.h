// Synthetic scenes for the core tests: wall segments and a ray-casting 2D laser simulator with
// seeded Gaussian range noise.
#pragma once

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam::testing {

struct Wall {
  Point2 a, b;
};
using Scene = std::vector<Wall>;

/// Axis-aligned rectangular room [x0, x1] x [y0, y1].
inline Scene Room(double x0, double y0, double x1, double y1) {
  return {{{x0, y0}, {x1, y0}}, {{x1, y0}, {x1, y1}}, {{x1, y1}, {x0, y1}}, {{x0, y1}, {x0, y0}}};
}

/// Appends a closed square pillar centred at c with half size h.
inline void AddPillar(Scene& scene, const Point2& c, double h) {
  const Scene box = Room(c.x() - h, c.y() - h, c.x() + h, c.y() + h);
  scene.insert(scene.end(), box.begin(), box.end());
}

/// A room with a pillar and a door-frame step: distinctive, but mostly straight walls.
inline Scene OfficeRoom() {
  Scene s = {{{0, 0}, {6, 0}},   {{6, 0}, {6, 2}},     {{6, 2}, {6.3, 2}}, {{6.3, 2}, {6.3, 3}},
             {{6.3, 3}, {6, 3}}, {{6, 3}, {6, 5}},     {{6, 5}, {0, 5}},   {{0, 5}, {0, 3.2}},
             {{0, 3.2}, {-0.4, 3.2}}, {{-0.4, 3.2}, {-0.4, 2.2}}, {{-0.4, 2.2}, {0, 2.2}},
             {{0, 2.2}, {0, 0}}};
  AddPillar(s, {2.0, 3.5}, 0.25);
  AddPillar(s, {4.2, 1.2}, 0.15);
  return s;
}

/// A corridor along x with door recesses on both sides.
inline Scene Corridor(double length) {
  Scene s;
  for (double x = 0.0; x < length; x += 3.0) {
    const double e = std::min(x + 3.0, length);
    s.push_back({{x, 0}, {x + 2.0, 0}});
    s.push_back({{x + 2.0, 0}, {x + 2.0, -0.3}});
    s.push_back({{x + 2.0, -0.3}, {e, -0.3}});
    s.push_back({{x + 1.0, 2.0}, {x, 2.0}});
    s.push_back({{e, 2.0}, {x + 1.0, 2.0}});
  }
  s.push_back({{0, 0}, {0, 2}});
  return s;
}

/// A 14 x 10 m hall around an 8 x 4 m block, with alcoves and pillars so that places differ:
/// a loop to drive around (mapper and localizer tests).
inline Scene LoopWorld() {
  Scene s = Room(0.0, 0.0, 14.0, 10.0);
  const Scene block = Room(3.0, 3.0, 11.0, 7.0);
  s.insert(s.end(), block.begin(), block.end());
  AddPillar(s, {0.6, 5.0}, 0.2);
  AddPillar(s, {13.4, 2.0}, 0.15);
  AddPillar(s, {7.0, 9.4}, 0.25);
  s.push_back({{5.0, 0.0}, {5.0, 0.6}});
  s.push_back({{5.0, 0.6}, {6.0, 0.6}});
  s.push_back({{9.0, 10.0}, {9.0, 9.4}});
  s.push_back({{14.0, 6.0}, {13.3, 6.5}});
  return s;
}

struct ScannerModel {
  int beams = 181;
  double fov_rad = M_PI;  ///< centred on the sensor's x axis
  double max_range_m = 30.0;
  double noise_sigma_m = 0.01;
};

/// Ray-casts the scene from T_world_sensor. Beams that hit nothing read max_range_m.
inline LaserScan SimulateScan(const Scene& scene, const Pose2& T_world_sensor,
                              const ScannerModel& model, std::mt19937& prng) {
  std::normal_distribution<double> noise(0.0, model.noise_sigma_m);
  LaserScan scan;
  scan.max_range_m = model.max_range_m;
  const bool full = model.fov_rad >= 2.0 * M_PI - 1e-9;
  const double step = full ? model.fov_rad / model.beams : model.fov_rad / (model.beams - 1);
  const Point2 o = T_world_sensor.Translation();
  for (int i = 0; i < model.beams; ++i) {
    const double angle = -model.fov_rad / 2.0 + i * step;
    const double phi = T_world_sensor.theta + angle;
    const Point2 u(std::cos(phi), std::sin(phi));
    double best = std::numeric_limits<double>::infinity();
    for (const Wall& w : scene) {
      const Point2 d = w.b - w.a;
      const double denom = u.x() * d.y() - u.y() * d.x();
      if (std::abs(denom) < 1e-12) continue;
      const Point2 ao = w.a - o;
      const double r = (ao.x() * d.y() - ao.y() * d.x()) / denom;
      const double t = (ao.x() * u.y() - ao.y() * u.x()) / denom;
      if (r > 1e-6 && t >= 0.0 && t <= 1.0) best = std::min(best, r);
    }
    scan.angles_rad.push_back(angle);
    scan.ranges_m.push_back(best < model.max_range_m ? best + noise(prng) : model.max_range_m);
  }
  return scan;
}

}  // namespace shape_slam::testing
