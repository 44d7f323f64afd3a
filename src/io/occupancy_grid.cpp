#include "shape_slam_io/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace shape_slam::io {
namespace {

/// A beam in the map frame: from the sensor to its end; `hit` when the end is a return.
struct Ray {
  Point2 from, to;
  bool hit = false;
};

/// The beams of a keyframe that see anything: returns at their range, beams without return
/// (range >= the scan's max range) up to max_free_range_m; no reading (NaN, <= 0): none.
std::vector<Ray> RaysOf(const ShapeSlam::KeyframeView& keyframe, double max_free_range_m) {
  const LaserScan& scan = *keyframe.scan;
  const Pose2 T_map_sensor = keyframe.T_map_robot * scan.T_robot_sensor;
  const PointTransform to_map(T_map_sensor);
  std::vector<Ray> rays;
  rays.reserve(scan.ranges_m.size());
  for (std::size_t i = 0; i < scan.ranges_m.size() && i < scan.angles_rad.size(); ++i) {
    const double r = scan.ranges_m[i];
    if (!std::isfinite(r) || r <= 0.0) continue;
    const bool hit = r < scan.max_range_m;
    const double length = hit ? r : std::min(scan.max_range_m, max_free_range_m);
    const Point2 end_sensor(length * std::cos(scan.angles_rad[i]),
                            length * std::sin(scan.angles_rad[i]));
    rays.push_back({T_map_sensor.Translation(), to_map(end_sensor), hit});
  }
  return rays;
}

/// The box around the walls and the rays of the keyframes (sensor positions and beam ends); the
/// origin alone when there is nothing. The rays are made keyframe by keyframe, never all kept.
std::pair<Point2, Point2> BoundingBox(const std::vector<Polyline>& walls,
                                      const std::vector<ShapeSlam::KeyframeView>& keyframes,
                                      double max_free_range_m) {
  Point2 min = Point2::Constant(std::numeric_limits<double>::infinity()), max = -min;
  for (const Polyline& wall : walls) {
    for (const Point2& p : wall) min = min.cwiseMin(p), max = max.cwiseMax(p);
  }
  for (const ShapeSlam::KeyframeView& keyframe : keyframes) {
    for (const Ray& ray : RaysOf(keyframe, max_free_range_m)) {
      min = min.cwiseMin(ray.from).cwiseMin(ray.to);
      max = max.cwiseMax(ray.from).cwiseMax(ray.to);
    }
  }
  if (!min.allFinite() || !max.allFinite()) return {Point2::Zero(), Point2::Zero()};
  return {min, max};
}

/// An empty (all unknown) grid covering the box [min, max] plus the margin.
OccupancyGrid EmptyGrid(const Point2& min, const Point2& max, const OccupancyGridParams& params) {
  const double res = params.resolution_m;
  OccupancyGrid grid;
  grid.resolution_m = res;
  const Point2 low = min.array() - params.margin_m, high = max.array() + params.margin_m;
  grid.origin_m = (low / res).array().floor() * res;
  const double width = std::floor((high.x() - grid.origin_m.x()) / res) + 1.0;
  const double height = std::floor((high.y() - grid.origin_m.y()) / res) + 1.0;
  if (width * height > static_cast<double>(params.max_cells)) {
    throw std::invalid_argument("occupancy grid of " + std::to_string(width) + " x " +
                                std::to_string(height) + " cells exceeds max_cells (" +
                                std::to_string(params.max_cells) + "): use a coarser resolution");
  }
  grid.width = static_cast<int>(width);
  grid.height = static_cast<int>(height);
  grid.cells.assign(static_cast<std::size_t>(grid.width) * grid.height, CellState::kUnknown);
  return grid;
}

void Set(OccupancyGrid& grid, const Eigen::Vector2i& cell, CellState state) {
  grid.cells[static_cast<std::size_t>(cell.y()) * grid.width + cell.x()] = state;
}

/// The cells a ray clears: up to its return, the return's own cell excluded; a ray without
/// return stops at the first wall it meets (the laser saw through it: glass, or a grazing beam).
std::vector<Eigen::Vector2i> FreeCells(const OccupancyGrid& grid, const Ray& ray) {
  std::vector<Eigen::Vector2i> cells = CellsOnSegment(grid, ray.from, ray.to);
  if (ray.hit) {
    if (!cells.empty()) cells.pop_back();
    return cells;
  }
  const auto wall = std::find_if(cells.begin(), cells.end(), [&](const Eigen::Vector2i& c) {
    return grid.At(c.x(), c.y()) == CellState::kOccupied;
  });
  cells.erase(wall, cells.end());
  return cells;
}

}  // namespace

void OccupancyGridParams::Validate() const {
  if (!(std::isfinite(resolution_m) && resolution_m > 0.0)) {
    throw std::invalid_argument("OccupancyGridParams::resolution_m must be > 0");
  }
  if (!(std::isfinite(max_free_range_m) && max_free_range_m >= 0.0)) {
    throw std::invalid_argument("OccupancyGridParams::max_free_range_m must be >= 0");
  }
  if (!(std::isfinite(margin_m) && margin_m >= 0.0)) {
    throw std::invalid_argument("OccupancyGridParams::margin_m must be >= 0");
  }
}

std::optional<Eigen::Vector2i> OccupancyGrid::CellOf(const Point2& p_map) const {
  const Point2 u = (p_map - origin_m) / resolution_m;
  if (!(u.x() >= 0.0 && u.y() >= 0.0 && u.x() < width && u.y() < height)) return std::nullopt;
  return Eigen::Vector2i(static_cast<int>(u.x()), static_cast<int>(u.y()));
}

std::size_t OccupancyGrid::Count(CellState state) const {
  return static_cast<std::size_t>(std::count(cells.begin(), cells.end(), state));
}

// Amanatides & Woo: step to whichever cell boundary the segment meets first. Exactly the
// Manhattan distance between the end cells in steps, so rounding can never overshoot b's cell.
std::vector<Eigen::Vector2i> CellsOnSegment(const OccupancyGrid& grid, const Point2& a,
                                            const Point2& b) {
  const Point2 ua = (a - grid.origin_m) / grid.resolution_m;
  const Point2 ub = (b - grid.origin_m) / grid.resolution_m;
  const Point2 d = ub - ua;
  Eigen::Vector2i cell(static_cast<int>(std::floor(ua.x())), static_cast<int>(std::floor(ua.y())));
  const Eigen::Vector2i last(static_cast<int>(std::floor(ub.x())),
                             static_cast<int>(std::floor(ub.y())));
  Eigen::Vector2i step;
  Point2 t_max, t_delta;
  for (int k = 0; k < 2; ++k) {
    step[k] = last[k] > cell[k] ? 1 : (last[k] < cell[k] ? -1 : 0);
    t_delta[k] = d[k] != 0.0 ? 1.0 / std::abs(d[k]) : std::numeric_limits<double>::infinity();
    const double boundary = step[k] > 0 ? cell[k] + 1.0 : cell[k];
    t_max[k] = step[k] != 0 ? (boundary - ua[k]) / d[k] : std::numeric_limits<double>::infinity();
  }
  const int steps = std::abs(last.x() - cell.x()) + std::abs(last.y() - cell.y());
  std::vector<Eigen::Vector2i> cells;
  cells.reserve(steps + 1);
  for (int i = 0;; ++i) {
    if (cell.x() >= 0 && cell.y() >= 0 && cell.x() < grid.width && cell.y() < grid.height) {
      cells.push_back(cell);
    }
    if (i == steps) break;
    const bool along_x = cell.y() == last.y() || (cell.x() != last.x() && t_max.x() < t_max.y());
    const int k = along_x ? 0 : 1;
    cell[k] += step[k];
    t_max[k] += t_delta[k];
  }
  return cells;
}

// One grid throughout (a second, walls-only copy would double the peak memory of a large map):
// the walls first, then the rays clear what is not a wall; a ray without return stops at the
// first wall cell, which only walls have, since clearing never touches them.
OccupancyGrid BuildOccupancyGrid(const std::vector<Polyline>& walls,
                                 const std::vector<ShapeSlam::KeyframeView>& keyframes,
                                 const OccupancyGridParams& params) {
  params.Validate();
  const auto [min, max] = BoundingBox(walls, keyframes, params.max_free_range_m);
  OccupancyGrid grid = EmptyGrid(min, max, params);
  for (const Polyline& wall : walls) {
    for (std::size_t i = 0; i < wall.size(); ++i) {
      const Point2& next = wall[std::min(i + 1, wall.size() - 1)];
      for (const Eigen::Vector2i& cell : CellsOnSegment(grid, wall[i], next)) {
        Set(grid, cell, CellState::kOccupied);
      }
    }
  }
  for (const ShapeSlam::KeyframeView& keyframe : keyframes) {
    for (const Ray& ray : RaysOf(keyframe, params.max_free_range_m)) {
      for (const Eigen::Vector2i& cell : FreeCells(grid, ray)) {
        if (grid.At(cell.x(), cell.y()) != CellState::kOccupied) Set(grid, cell, CellState::kFree);
      }
    }
  }
  return grid;
}

}  // namespace shape_slam::io
