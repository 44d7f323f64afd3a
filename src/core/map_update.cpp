#include "shape_slam/map_update.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <numeric>
#include <stdexcept>
#include <string>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/geometry.h"

namespace shape_slam {
namespace {

// Arc-length position of a polyline projection.
double ArcPosition(const Polyline& polyline, const PolylineProjection& projection) {
  double s = 0.0;
  for (std::size_t i = 0; i < projection.segment; ++i) s += (polyline[i + 1] - polyline[i]).norm();
  if (polyline.size() >= 2) {
    s += projection.t * (polyline[projection.segment + 1] - polyline[projection.segment]).norm();
  }
  return s;
}

double ArcPositionOf(const Point2& p, const Polyline& polyline) {
  return ArcPosition(polyline, ProjectOntoPolyline(p, polyline));
}

WeightedPolyline Reversed(WeightedPolyline w) {
  std::reverse(w.points.begin(), w.points.end());
  std::reverse(w.weights.begin(), w.weights.end());
  return w;
}

// Weight of a weighted polyline at a projection onto it (linear along the segment).
double WeightAt(const WeightedPolyline& w, const PolylineProjection& projection) {
  if (w.points.size() < 2) return w.weights.empty() ? 1.0 : w.weights.front();
  const double a = w.weights[projection.segment], b = w.weights[projection.segment + 1];
  return a + projection.t * (b - a);
}

// The point at arc position s of segment [i, i+1] starting at arc position a, with its weight.
std::pair<Point2, double> PointAt(const WeightedPolyline& w, std::size_t i, double a,
                                  double length, double s) {
  const double t = std::clamp((s - a) / length, 0.0, 1.0);
  return {w.points[i] + t * (w.points[i + 1] - w.points[i]),
          w.weights[i] + t * (w.weights[i + 1] - w.weights[i])};
}

void Append(WeightedPolyline& out, const std::pair<Point2, double>& vertex) {
  if (!out.points.empty() && (out.points.back() - vertex.first).squaredNorm() < 1e-18) return;
  out.points.push_back(vertex.first);
  out.weights.push_back(vertex.second);
}

void Append(WeightedPolyline& out, const WeightedPolyline& part) {
  for (std::size_t i = 0; i < part.points.size(); ++i) Append(out, {part.points[i], part.weights[i]});
}

// The part of a weighted polyline between arc positions s0 <= s1, end points interpolated.
WeightedPolyline SubPolyline(const WeightedPolyline& w, double s0, double s1) {
  WeightedPolyline out;
  double walked = 0.0;
  for (std::size_t i = 0; i + 1 < w.points.size(); ++i) {
    const double length = (w.points[i + 1] - w.points[i]).norm();
    const double a = walked, b = walked + length;
    walked = b;
    if (b < s0 || a > s1 || length <= 0.0) continue;
    if (out.points.empty()) Append(out, PointAt(w, i, a, length, std::max(s0, a)));
    Append(out, PointAt(w, i, a, length, std::min(s1, b)));
  }
  return out;
}

// The partner of a model-body point on the perceived body: along the simulated laser ray from
// the viewpoint through it (§5.2), or along the model's normal where the ray meets the model
// at a grazing angle (there the ray intersection is ill-conditioned).
Point2 Partner(const Point2& m, const Point2& model_direction, const Polyline& perceived,
               const Point2& viewpoint, double min_incidence_rad) {
  const Point2 ray = m - viewpoint;
  const double ray_length = ray.norm();
  if (ray_length > 1e-9) {
    const Point2 u = ray / ray_length;
    const double incidence = std::abs(u.x() * model_direction.y() - u.y() * model_direction.x());
    if (incidence >= std::sin(min_incidence_rad)) {
      double best = std::numeric_limits<double>::infinity();
      Point2 hit = m;
      for (std::size_t i = 0; i + 1 < perceived.size(); ++i) {
        const Point2 d = perceived[i + 1] - perceived[i];
        const double denom = u.x() * d.y() - u.y() * d.x();
        if (std::abs(denom) < 1e-12) continue;
        const Point2 va = perceived[i] - viewpoint;
        const double r = (va.x() * d.y() - va.y() * d.x()) / denom;  // along the ray
        const double t = (va.x() * u.y() - va.y() * u.x()) / denom;  // along the segment
        if (t < 0.0 || t > 1.0 || r <= 0.0) continue;
        if (std::abs(r - ray_length) < best) {
          best = std::abs(r - ray_length);
          hit = viewpoint + r * u;
        }
      }
      if (std::isfinite(best)) return hit;
    }
  }
  return ProjectOntoPolyline(m, perceived).point;
}

// Averages the two bodies at points spaced along the model body (§5.2, weighted average).
WeightedPolyline AverageBodies(const WeightedPolyline& model_body,
                               const WeightedPolyline& perceived_body, const Point2& viewpoint,
                               const MapUpdateParams& params) {
  WeightedPolyline out;
  const Polyline& m = model_body.points;
  for (std::size_t i = 0; i + 1 < m.size(); ++i) {
    const Point2 d = m[i + 1] - m[i];
    const double length = d.norm();
    if (length <= 0.0) continue;
    const int n = std::max(1, static_cast<int>(std::ceil(length / params.merge_sample_spacing_m)));
    for (int k = 0; k <= n; ++k) {
      const auto [p, w_model] = PointAt(model_body, i, 0.0, length, length * k / n);
      const Point2 q =
          Partner(p, d / length, perceived_body.points, viewpoint, params.min_incidence_rad);
      const double w_new = WeightAt(perceived_body, ProjectOntoPolyline(q, perceived_body.points));
      Append(out, {(w_model * p + w_new * q) / (w_model + w_new),
                   std::min(w_model + w_new, params.max_support)});
    }
  }
  return out;
}

// DCE on a weighted polyline; the kept vertices keep their weights (DCE keeps original
// vertices, so they are found again in order).
WeightedPolyline Simplify(const WeightedPolyline& w, double threshold_m, double max_deviation_m) {
  const Polyline kept = SimplifyDceBounded(w.points, threshold_m, max_deviation_m);
  WeightedPolyline out;
  std::size_t j = 0;
  for (const Point2& p : kept) {
    while (j < w.points.size() && w.points[j] != p) ++j;
    if (j == w.points.size()) break;  // cannot happen: DCE keeps vertices in order
    out.points.push_back(p);
    out.weights.push_back(w.weights[j]);
  }
  return out;
}

// Overlap of a perceived polyline with a map polyline (both map frame): the RMS distance and
// direction difference of the perceived samples whose projection is inside the map polyline.
struct Overlap {
  double length_m = 0.0;
  double rms_m = 0.0;
  double angle_rms_rad = 0.0;
};

Overlap MeasureOverlap(const Polyline& perceived, const Polyline& model, double spacing_m) {
  Overlap overlap;
  if (perceived.size() < 2 || model.size() < 2) return overlap;
  double sum_d2 = 0.0, sum_a2 = 0.0, covered = 0.0;
  int count = 0;
  const std::size_t last = model.size() - 2;
  for (std::size_t i = 0; i + 1 < perceived.size(); ++i) {
    const Point2 d = perceived[i + 1] - perceived[i];
    const double length = d.norm();
    if (length <= 0.0) continue;
    const int n = std::max(1, static_cast<int>(std::ceil(length / spacing_m)));
    for (int k = 0; k < n; ++k) {
      const PolylineProjection proj = ProjectOntoPolyline(perceived[i] + d * ((k + 0.5) / n), model);
      if ((proj.segment == 0 && proj.t <= 0.0) || (proj.segment == last && proj.t >= 1.0)) continue;
      const Point2 md = model[proj.segment + 1] - model[proj.segment];
      // Undirected: map polylines keep the orientation of their first sighting.
      const double angle = std::atan(std::abs(d.x() * md.y() - d.y() * md.x()) /
                                     std::max(std::abs(d.dot(md)), 1e-12));
      sum_d2 += proj.squared_distance;
      sum_a2 += angle * angle;
      covered += length / n;
      ++count;
    }
  }
  if (count == 0) return overlap;
  overlap.length_m = covered;
  overlap.rms_m = std::sqrt(sum_d2 / count);
  overlap.angle_rms_rad = std::sqrt(sum_a2 / count);
  return overlap;
}

bool Corresponds(const Polyline& perceived, const Polyline& model, const MapUpdateParams& params) {
  const Overlap o = MeasureOverlap(perceived, model, params.merge_sample_spacing_m * 2.0);
  const double shorter = std::min(PolylineLength(perceived), PolylineLength(model));
  const double needed =
      std::min(params.merge_min_overlap_m, params.merge_min_overlap_fraction * shorter);
  return o.length_m > 0.0 && o.length_m >= needed && o.rms_m <= params.merge_max_misfit_m &&
         o.angle_rms_rad <= params.merge_max_angle_rad;
}

WeightedPolyline Unweighted(const Polyline& points) {
  return {points, std::vector<double>(points.size(), 1.0)};
}

std::vector<PolylineId> CorrespondingMapPolylines(const PolylineMap& map, const Polyline& perceived,
                                                  const MapUpdateParams& params) {
  Point2 min = perceived.front(), max = perceived.front();
  for (const Point2& p : perceived) min = min.cwiseMin(p), max = max.cwiseMax(p);
  const Point2 margin = Point2::Constant(params.merge_max_misfit_m + 1e-6);
  std::vector<PolylineId> ids;
  for (const PolylineId id : map.IdsNear(min - margin, max + margin)) {
    if (Corresponds(perceived, map.Get(id).points, params)) ids.push_back(id);
  }
  return ids;
}

// Whether a point lies within `tolerance` of a polyline (not empty). The segment that was near
// the previous query is tried first (`hint`): consecutive samples along a polyline are near the
// same segment, so a typical query costs one segment instead of a scan over all of them.
bool NearPolyline(const Point2& p, const Polyline& polyline, double tolerance2, std::size_t& hint) {
  if (polyline.size() == 1) return (p - polyline.front()).squaredNorm() <= tolerance2;
  const auto near = [&](std::size_t i) {
    return SquaredDistanceToSegment(p, polyline[i], polyline[i + 1]) <= tolerance2;
  };
  if (hint + 1 < polyline.size() && near(hint)) return true;
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    if (near(i)) {
      hint = i;
      return true;
    }
  }
  return false;
}

// Whether every point sampled along `a` (every spacing_m) lies within `tolerance` of `b` or of
// `c` (which may be empty).
bool AllWithin(const Polyline& a, const Polyline& b, const Polyline& c, double spacing_m,
               double tolerance) {
  const double tolerance2 = tolerance * tolerance;
  std::size_t hint_b = 0, hint_c = 0;
  for (std::size_t i = 0; i + 1 < a.size(); ++i) {
    const Point2 d = a[i + 1] - a[i];
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / spacing_m)));
    for (int k = 0; k <= n; ++k) {
      const Point2 p = a[i] + d * (static_cast<double>(k) / n);
      if (!NearPolyline(p, b, tolerance2, hint_b) &&
          (c.empty() || !NearPolyline(p, c, tolerance2, hint_c))) {
        return false;
      }
    }
  }
  return true;
}

// A merge is sound when the result stays close to its inputs along its whole length and still
// covers the model: anything else (a polyline doubling back, a segment cutting a corner) is a
// merge gone wrong, and the map keeps the inputs apart instead.
bool SoundMerge(const Polyline& merged, const Polyline& model, const Polyline& perceived,
                const MapUpdateParams& params) {
  const double tolerance = 2.0 * params.merge_max_misfit_m;
  const double spacing = params.merge_check_spacing_m;
  return merged.size() >= 2 && AllWithin(merged, model, perceived, spacing, tolerance) &&
         AllWithin(model, merged, {}, spacing, tolerance);
}

// Whether more than `fraction` of a perceived polyline lies within `clearance_m` of the map.
bool NearMap(const PolylineMap& map, const Polyline& perceived, double clearance_m,
             double fraction, double spacing_m) {
  Point2 min = perceived.front(), max = perceived.front();
  for (const Point2& p : perceived) min = min.cwiseMin(p), max = max.cwiseMax(p);
  const Point2 margin = Point2::Constant(clearance_m);
  const std::vector<PolylineId> ids = map.IdsNear(min - margin, max + margin);
  if (ids.empty()) return false;
  int near = 0, total = 0;
  for (std::size_t i = 0; i + 1 < perceived.size(); ++i) {
    const Point2 d = perceived[i + 1] - perceived[i];
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / spacing_m)));
    for (int k = 0; k < n; ++k) {
      const Point2 p = perceived[i] + d * ((k + 0.5) / n);
      ++total;
      for (const PolylineId id : ids) {
        if (ProjectOntoPolyline(p, map.Get(id).points).squared_distance <= clearance_m * clearance_m) {
          ++near;
          break;
        }
      }
    }
  }
  return near > fraction * total;
}

// Merges a perceived polyline into the corresponding map polylines: into the first, which then
// absorbs the others (a perceived polyline bridging two map polylines joins them).
bool MergeIntoMap(PolylineMap& map, const Polyline& perceived, const std::vector<PolylineId>& ids,
                  const Point2& viewpoint, const MapUpdateParams& params, MapUpdateStats& stats) {
  MapPolyline target = map.Get(ids.front());
  WeightedPolyline merged = MergePolylines({target.points, target.support}, Unweighted(perceived),
                                           viewpoint, params);
  if (!SoundMerge(merged.points, target.points, perceived, params)) return false;
  for (std::size_t k = 1; k < ids.size(); ++k) {
    const MapPolyline& other = map.Get(ids[k]);
    WeightedPolyline joined = MergePolylines(merged, {other.points, other.support}, viewpoint, params);
    if (!SoundMerge(joined.points, merged.points, other.points, params)) continue;
    merged = std::move(joined);
    target.observations = std::max(target.observations, other.observations);
    map.Remove(ids[k]);
    ++stats.joined;
  }
  target.points = std::move(merged.points);
  target.support = std::move(merged.weights);
  target.observations += 1;
  target.contradictions = 0;
  map.Replace(ids.front(), std::move(target));
  ++stats.merged;
  return true;
}

// Index of the beam whose direction is nearest to `bearing`, with beams sorted by angle.
std::optional<std::size_t> NearestBeam(const std::vector<std::size_t>& order, const LaserScan& scan,
                                       double bearing, double tolerance_rad) {
  if (order.empty()) return std::nullopt;
  const auto it = std::lower_bound(order.begin(), order.end(), bearing, [&](std::size_t i, double b) {
    return scan.angles_rad[i] < b;
  });
  std::optional<std::size_t> best;
  double best_diff = tolerance_rad;
  for (auto c = (it == order.begin() ? it : it - 1); c != order.end() && c <= it; ++c) {
    const double diff = std::abs(NormalizeAngle(scan.angles_rad[*c] - bearing));
    if (diff <= best_diff) best_diff = diff, best = *c;
  }
  return best;
}

// True when most of the visible piece lies in front of the scan's readings by more than the
// margin: the rays passed through where the map says there is a wall.
bool Contradicted(const Polyline& piece_sensor, const LaserScan& scan,
                  const std::vector<std::size_t>& order, double beam_step_rad,
                  const MapUpdateParams& params) {
  int through = 0, considered = 0;
  for (std::size_t i = 0; i + 1 < piece_sensor.size(); ++i) {
    const Point2 d = piece_sensor[i + 1] - piece_sensor[i];
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / params.check_sample_spacing_m)));
    for (int k = 0; k < n; ++k) {
      const Point2 p = piece_sensor[i] + d * ((k + 0.5) / n);
      const auto beam = NearestBeam(order, scan, std::atan2(p.y(), p.x()), beam_step_rad);
      if (!beam) continue;
      const double r = scan.ranges_m[*beam];
      if (!std::isfinite(r) || r <= 0.0 || r >= scan.max_range_m) continue;  // no evidence
      ++considered;
      if (r > p.norm() + params.contradiction_margin_m) ++through;
    }
  }
  return considered >= 3 && 2 * through > considered;
}

void CountContradictions(PolylineMap& map, const std::vector<VisiblePolyline>& visible,
                         const LaserScan& scan, const std::vector<PolylineId>& touched,
                         const MapUpdateParams& params, MapUpdateStats& stats) {
  std::vector<std::size_t> order(scan.angles_rad.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return scan.angles_rad[a] < scan.angles_rad[b]; });
  const double step = order.size() > 1 ? std::abs(scan.angles_rad[order.back()] -
                                                  scan.angles_rad[order.front()]) /
                                             (order.size() - 1)
                                       : 0.0;
  std::vector<PolylineId> counted;
  for (const VisiblePolyline& piece : visible) {
    const PolylineId id = piece.source;
    if (!map.Contains(id) || std::count(touched.begin(), touched.end(), id) ||
        std::count(counted.begin(), counted.end(), id)) {
      continue;
    }
    if (!Contradicted(piece.points_sensor, scan, order, step, params)) continue;
    counted.push_back(id);
    MapPolyline polyline = map.Get(id);
    polyline.contradictions += 1;
    if (polyline.observations <= params.drop_max_observations &&
        polyline.contradictions >= params.drop_min_contradictions) {
      map.Remove(id);
      ++stats.dropped;
    } else {
      map.Replace(id, std::move(polyline));
    }
  }
}

}  // namespace

void MapUpdateParams::Validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("MapUpdateParams::") + name + " must be > 0");
    }
  };
  positive(dce_threshold_m, "dce_threshold_m");
  positive(check_sample_spacing_m, "check_sample_spacing_m");
  positive(merge_check_spacing_m, "merge_check_spacing_m");
  if (!(untrusted_near_fraction >= 0.0 && untrusted_near_fraction <= 1.0)) {
    throw std::invalid_argument("MapUpdateParams::untrusted_near_fraction must be in [0, 1]");
  }
  positive(max_deviation_m, "max_deviation_m");
  positive(merge_sample_spacing_m, "merge_sample_spacing_m");
  positive(max_support, "max_support");
  positive(merge_max_misfit_m, "merge_max_misfit_m");
  positive(merge_max_angle_rad, "merge_max_angle_rad");
  positive(contradiction_margin_m, "contradiction_margin_m");
  positive(untrusted_clearance_m, "untrusted_clearance_m");
  positive(explained_distance_m, "explained_distance_m");
  if (!(explained_fraction >= 0.0 && explained_fraction <= 1.0)) {
    throw std::invalid_argument("MapUpdateParams::explained_fraction must be in [0, 1]");
  }
  if (!(min_incidence_rad >= 0.0 && min_incidence_rad < M_PI / 2)) {
    throw std::invalid_argument("MapUpdateParams::min_incidence_rad must be in [0, pi/2)");
  }
  if (!(merge_min_overlap_m >= 0.0) || !(min_new_length_m >= 0.0) ||
      !(merge_min_overlap_fraction >= 0.0 && merge_min_overlap_fraction <= 1.0)) {
    throw std::invalid_argument(
        "MapUpdateParams: merge_min_overlap_m, min_new_length_m must be >= 0 and "
        "merge_min_overlap_fraction in [0, 1]");
  }
  if (drop_max_observations < 0 || drop_min_contradictions < 1) {
    throw std::invalid_argument(
        "MapUpdateParams: drop_max_observations must be >= 0, drop_min_contradictions >= 1");
  }
}

WeightedPolyline MergePolylines(const WeightedPolyline& model, const WeightedPolyline& perceived,
                                const Point2& viewpoint, const MapUpdateParams& params) {
  if (perceived.points.size() < 2) return model;
  if (model.points.size() < 2) return Simplify(perceived, params.dce_threshold_m, params.max_deviation_m);
  // Orient the perceived polyline like the model.
  const WeightedPolyline a =
      ArcPositionOf(perceived.points.front(), model.points) >
              ArcPositionOf(perceived.points.back(), model.points)
          ? Reversed(perceived)
          : perceived;
  const double length_m = PolylineLength(model.points), length_a = PolylineLength(a.points);
  // End points mapped to the other polyline (Fig. 5b): they delimit head, body and tail.
  const double s_a0 = ArcPositionOf(a.points.front(), model.points);
  const double s_a1 = ArcPositionOf(a.points.back(), model.points);
  const double t_m0 = ArcPositionOf(model.points.front(), a.points);
  const double t_m1 = ArcPositionOf(model.points.back(), a.points);
  constexpr double kEps = 1e-6;
  const bool head_from_a = t_m0 > kEps;           // a starts before the model does
  const bool tail_from_a = t_m1 < length_a - kEps;  // a ends after the model does
  const WeightedPolyline head =
      head_from_a ? SubPolyline(a, 0.0, t_m0) : SubPolyline(model, 0.0, s_a0);
  const WeightedPolyline tail =
      tail_from_a ? SubPolyline(a, t_m1, length_a) : SubPolyline(model, s_a1, length_m);
  const WeightedPolyline model_body =
      SubPolyline(model, head_from_a ? 0.0 : s_a0, tail_from_a ? length_m : s_a1);
  const WeightedPolyline a_body =
      SubPolyline(a, head_from_a ? t_m0 : 0.0, tail_from_a ? t_m1 : length_a);
  // A head or tail of (almost) zero length is just the body's end point: averaged with the body.
  auto has_length = [](const WeightedPolyline& part) { return PolylineLength(part.points) > 1e-6; };
  WeightedPolyline merged;
  if (has_length(head)) Append(merged, head);
  if (model_body.points.size() >= 2 && a_body.points.size() >= 2) {
    Append(merged, AverageBodies(model_body, a_body, viewpoint, params));
  } else {
    Append(merged, model_body);
  }
  if (has_length(tail)) Append(merged, tail);
  return Simplify(merged, params.dce_threshold_m, params.max_deviation_m);
}

MapUpdateStats UpdateMap(PolylineMap& map, const std::vector<Polyline>& perceived_map,
                         const Pose2& T_map_sensor, const std::vector<VisiblePolyline>& visible,
                         const LaserScan& scan, bool pose_trusted, const MapUpdateParams& params) {
  params.Validate();
  MapUpdateStats stats;
  const Point2 viewpoint = T_map_sensor.Translation();
  std::vector<PolylineId> touched;
  for (const Polyline& perceived : perceived_map) {
    if (perceived.size() < 2 || PolylineLength(perceived) < params.min_new_length_m) continue;
    if (!pose_trusted &&
        NearMap(map, perceived, params.untrusted_clearance_m, params.untrusted_near_fraction,
                params.check_sample_spacing_m)) {
      continue;
    }
    const std::vector<PolylineId> ids =
        pose_trusted ? CorrespondingMapPolylines(map, perceived, params) : std::vector<PolylineId>{};
    if (!ids.empty() && MergeIntoMap(map, perceived, ids, viewpoint, params, stats)) {
      touched.push_back(ids.front());
      continue;
    }
    if (!ids.empty()) ++stats.unsound;
    // Already represented (clutter seen again from another side, a fragment of a known wall):
    // adding it would only duplicate the map.
    if (NearMap(map, perceived, params.explained_distance_m, params.explained_fraction,
                params.check_sample_spacing_m)) {
      ++stats.explained;
      continue;
    }
    const WeightedPolyline simplified = Simplify(Unweighted(perceived), params.dce_threshold_m, params.max_deviation_m);
    touched.push_back(map.Add({simplified.points, simplified.weights, 1, 0}));
    ++stats.added;
  }
  // An unconfirmed pose could make right polylines look contradicted: count only confirmed views.
  if (pose_trusted) CountContradictions(map, visible, scan, touched, params, stats);
  for (const PolylineId id : touched) {
    if (map.Contains(id)) stats.touched.push_back(id);
  }
  return stats;
}

}  // namespace shape_slam
