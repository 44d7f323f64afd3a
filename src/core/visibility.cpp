#include "shape_slam/visibility.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

#include "shape_slam/geometry.h"

namespace shape_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The angular sweep's bins over the field of view.
struct Sweep {
  double start = -M_PI;  // bearing of the right edge of bin 0
  double width = 0.0;    // bin width
  int bins = 0;
  bool full_circle = true;

  std::vector<Point2> edge_dir;    // unit direction of edge k, k in [0, bins]
  std::vector<Point2> centre_dir;  // unit direction of the centre ray of bin k

  double Edge(int k) const { return start + k * width; }
  // Directions of (possibly wrapped) edge / bin indices, from the tables.
  const Point2& EdgeDir(int k) const { return edge_dir[k <= bins ? k : k % bins]; }
  const Point2& CentreDir(int k) const { return centre_dir[k % bins]; }
  // Bearing relative to the start, in [0, 2 pi).
  double Offset(double bearing) const {
    double o = std::fmod(bearing - start, 2.0 * M_PI);
    return o < 0.0 ? o + 2.0 * M_PI : o;
  }
};

Sweep BuildSweep(const VisibilityParams& params) {
  Sweep s;
  s.full_circle = params.fov_rad >= 2.0 * M_PI - 1e-9;
  const double fov = s.full_circle ? 2.0 * M_PI : params.fov_rad;
  s.bins = std::max(1, static_cast<int>(std::ceil(fov / params.angular_resolution_rad)));
  s.width = fov / s.bins;
  s.start = s.full_circle ? -M_PI : -fov / 2.0;
  s.edge_dir.reserve(s.bins + 1);
  s.centre_dir.reserve(s.bins);
  for (int k = 0; k <= s.bins; ++k) s.edge_dir.emplace_back(std::cos(s.Edge(k)), std::sin(s.Edge(k)));
  for (int k = 0; k < s.bins; ++k) {
    const double phi = s.Edge(k) + 0.5 * s.width;
    s.centre_dir.emplace_back(std::cos(phi), std::sin(phi));
  }
  return s;
}

// The sweep of the last field of view and resolution asked for in this thread: scans of one
// sensor share them, and the direction tables cost two sincos per bin.
const Sweep& MakeSweep(const VisibilityParams& params) {
  thread_local Sweep cached;
  thread_local double cached_fov = -1.0, cached_resolution = -1.0;
  if (params.fov_rad != cached_fov || params.angular_resolution_rad != cached_resolution) {
    cached = BuildSweep(params);
    cached_fov = params.fov_rad;
    cached_resolution = params.angular_resolution_rad;
  }
  return cached;
}

// Distance along the ray of bearing phi from the origin to the line through a, b, and the
// parameter t of the hit on [a, b]; nullopt when the ray is parallel or points away.
struct RayHit {
  double depth;
  double t;
};
std::optional<RayHit> Intersect(const Point2& u, const Point2& a, const Point2& b) {
  const Point2 d = b - a;
  const double denom = u.x() * d.y() - u.y() * d.x();
  if (std::abs(denom) < 1e-15) return std::nullopt;
  const double r = (a.x() * d.y() - a.y() * d.x()) / denom;
  const double t = (a.x() * u.y() - a.y() * u.x()) / denom;
  if (r <= 0.0) return std::nullopt;
  return RayHit{r, t};
}

// A segment in the sensor frame, clipped to the range disc, with its bins.
struct SweptSegment {
  PolylineId polyline;
  std::uint32_t segment;
  Point2 a, b;             // sensor frame, the whole segment
  double t0 = 0, t1 = 1;   // the part inside the range disc
  int first_bin = 0, num_bins = 0;
};

// Parameter interval of [a, b] inside the disc of radius r around the origin.
bool ClipToDisc(const Point2& a, const Point2& b, double r, double& t0, double& t1) {
  const Point2 d = b - a;
  const double qa = d.squaredNorm(), qb = 2.0 * a.dot(d), qc = a.squaredNorm() - r * r;
  if (qa <= 0.0) return qc <= 0.0;
  const double disc = qb * qb - 4.0 * qa * qc;
  if (disc < 0.0) return false;
  const double sq = std::sqrt(disc);
  t0 = std::max(0.0, (-qb - sq) / (2.0 * qa));
  t1 = std::min(1.0, (-qb + sq) / (2.0 * qa));
  return t0 < t1;
}

// The bins spanned by a segment part (nullopt if outside the field of view or degenerate).
bool AssignBins(const Sweep& sweep, SweptSegment& s) {
  const Point2 p0 = s.a + s.t0 * (s.b - s.a), p1 = s.a + s.t1 * (s.b - s.a);
  if (p0.norm() < 1e-9 || p1.norm() < 1e-9) return false;  // passes through the viewpoint
  double b0 = std::atan2(p0.y(), p0.x());
  const double span = NormalizeAngle(std::atan2(p1.y(), p1.x()) - b0);
  double lo = sweep.Offset(span >= 0 ? b0 : b0 + span);
  double hi = lo + std::abs(span);
  const double fov = sweep.bins * sweep.width;
  if (!sweep.full_circle) {
    if (lo >= fov && hi < 2.0 * M_PI) return false;
    if (lo >= fov) {  // starts before the right edge and wraps into the view
      lo -= 2.0 * M_PI;
      hi -= 2.0 * M_PI;
    }
    lo = std::max(lo, 0.0);
    hi = std::min(hi, fov);
    if (hi <= lo) return false;
  }
  s.first_bin = static_cast<int>(std::floor(lo / sweep.width));
  const int last_bin = static_cast<int>(std::floor(std::nextafter(hi, -kInf) / sweep.width));
  s.num_bins = last_bin - s.first_bin + 1;
  return s.num_bins > 0;
}

// The part [ta, tb] of a segment that lies between the edge rays of one of its bins (empty when
// tb <= ta), and the depth of the segment in that bin: the distance of the part's nearest point.
// (Along the centre ray alone, a polyline would hide its own continuation at a corner sharing
// the bin.)
struct BinPart {
  double ta = 0.0, tb = 0.0;
  double depth = kInf;
  bool Empty() const { return tb <= ta; }
};

// Appends the parts of a segment in its bins, first_bin first. Each edge ray between two bins
// is intersected once: it bounds the part in the bin below and the part in the bin above.
void AppendBinParts(const Sweep& sweep, const SweptSegment& s, std::vector<BinPart>& parts) {
  const Point2 d = s.b - s.a;
  const bool ccw = s.a.x() * d.y() - s.a.y() * d.x() > 0.0;  // bearing grows with t
  const double t_low = ccw ? s.t0 : s.t1, t_high = ccw ? s.t1 : s.t0;  // t at the lower/upper edge
  std::optional<RayHit> lower = Intersect(sweep.EdgeDir(s.first_bin), s.a, s.b);
  for (int k = s.first_bin; k < s.first_bin + s.num_bins; ++k) {
    const std::optional<RayHit> upper = Intersect(sweep.EdgeDir(k + 1), s.a, s.b);
    const double lo = lower ? std::clamp(lower->t, s.t0, s.t1) : t_low;
    const double hi = upper ? std::clamp(upper->t, s.t0, s.t1) : t_high;
    BinPart part{std::min(lo, hi), std::max(lo, hi)};
    if (!part.Empty()) {
      const Point2 p0 = s.a + part.ta * d, p1 = s.a + part.tb * d;
      part.depth = std::sqrt(SquaredDistanceToSegment(Point2::Zero(), p0, p1));
    }
    parts.push_back(part);
    lower = upper;
  }
}

std::vector<SweptSegment> GatherSegments(
    const std::unordered_map<PolylineId, Polyline>& polylines, const SegmentIndex& index,
    const Pose2& T_map_sensor, const VisibilityParams& params, const Sweep& sweep) {
  const PointTransform T_sensor_map(T_map_sensor.Inverse());
  std::vector<SweptSegment> out;
  for (const SegmentRef& ref : index.QueryDisc(T_map_sensor.Translation(), params.max_range_m)) {
    const auto it = polylines.find(ref.polyline);
    if (it == polylines.end() || ref.segment + 1 >= it->second.size()) continue;
    SweptSegment s{ref.polyline, ref.segment, T_sensor_map(it->second[ref.segment]),
                   T_sensor_map(it->second[ref.segment + 1])};
    if ((s.b - s.a).squaredNorm() <= 0.0) continue;
    if (!ClipToDisc(s.a, s.b, params.max_range_m, s.t0, s.t1)) continue;
    if (AssignBins(sweep, s)) out.push_back(s);
  }
  return out;
}

// The parts of every segment in its bins: segment i's are parts[begin[i], begin[i + 1]).
struct SegmentBinParts {
  std::vector<BinPart> parts;
  std::vector<std::size_t> begin;
};

// The range the scan saw along the centre ray of a bin: the nearest beam's, if one lies within
// a beam step of it (NaN otherwise, and for a beam without a reading).
double SeenRange(const Sweep& sweep, int bin, const SeenRays& seen) {
  const std::vector<double>& b = seen.bearings_rad;
  if (b.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  const double phi = NormalizeAngle(sweep.Edge(bin) + 0.5 * sweep.width);
  const auto it = std::lower_bound(b.begin(), b.end(), phi);
  std::size_t i = static_cast<std::size_t>(it - b.begin());
  if (i == b.size() || (i > 0 && phi - b[i - 1] < b[i] - phi)) --i;
  const double step = (b.back() - b.front()) / static_cast<double>(b.size() - 1);
  if (std::abs(NormalizeAngle(b[i] - phi)) > step) return std::numeric_limits<double>::quiet_NaN();
  return seen.ranges_m[i];
}

// Parts nearer than the scan's beam of their bin by more than the margin are emptied: the beam
// went past them (SeenRays).
void DropSeenThrough(const Sweep& sweep, const std::vector<SweptSegment>& segments,
                     const SeenRays& seen, SegmentBinParts& bin_parts) {
  std::vector<double> range(sweep.bins);
  for (int k = 0; k < sweep.bins; ++k) range[k] = SeenRange(sweep, k, seen);
  for (std::size_t i = 0; i < segments.size(); ++i) {
    BinPart* parts = bin_parts.parts.data() + bin_parts.begin[i];
    for (int j = 0; j < segments[i].num_bins; ++j) {
      const double r = range[(segments[i].first_bin + j) % sweep.bins];
      if (!parts[j].Empty() && parts[j].depth < r - seen.margin_m) parts[j] = BinPart{};
    }
  }
}

SegmentBinParts BinPartsOf(const Sweep& sweep, const std::vector<SweptSegment>& segments) {
  SegmentBinParts out;
  out.begin.reserve(segments.size() + 1);
  out.begin.push_back(0);
  for (const SweptSegment& s : segments) {
    AppendBinParts(sweep, s, out.parts);
    out.begin.push_back(out.parts.size());
  }
  return out;
}

std::vector<double> BuildZBuffer(const Sweep& sweep, const std::vector<SweptSegment>& segments,
                                 const SegmentBinParts& bin_parts) {
  std::vector<double> zbuffer(sweep.bins, kInf);
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const BinPart* parts = bin_parts.parts.data() + bin_parts.begin[i];
    for (int j = 0; j < segments[i].num_bins; ++j) {
      double& z = zbuffer[(segments[i].first_bin + j) % sweep.bins];
      if (!parts[j].Empty()) z = std::min(z, parts[j].depth);
    }
  }
  return zbuffer;
}

// Visible parameter intervals [ta, tb] of a segment (its bin parts given), clipped at the bin
// edge rays, sorted and merged into `merged`; `scratch` is reused storage.
using Intervals = std::vector<std::pair<double, double>>;

void VisibleIntervals(const Sweep& sweep, const SweptSegment& s, const BinPart* parts,
                      const std::vector<double>& zbuffer, double tolerance, Intervals& scratch,
                      Intervals& merged) {
  scratch.clear();
  for (int j = 0; j < s.num_bins; ++j) {
    if (parts[j].Empty()) continue;
    if (parts[j].depth > zbuffer[(s.first_bin + j) % sweep.bins] + tolerance) continue;
    scratch.emplace_back(parts[j].ta, parts[j].tb);
  }
  std::sort(scratch.begin(), scratch.end());
  merged.clear();
  for (const auto& iv : scratch) {
    if (!merged.empty() && iv.first <= merged.back().second + 1e-9) {
      merged.back().second = std::max(merged.back().second, iv.second);
    } else {
      merged.push_back(iv);
    }
  }
}

// Sum of the bearing increments along a polyline (positive: counter-clockwise).
double TurnedBearing(const Polyline& p) {
  double total = 0.0;
  double bearing = p.empty() ? 0.0 : std::atan2(p[0].y(), p[0].x());
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    const double next = std::atan2(p[i + 1].y(), p[i + 1].x());
    total += NormalizeAngle(next - bearing);
    bearing = next;
  }
  return total;
}

// Assembles visible intervals into pieces that follow their source polyline, continuing a
// piece across a vertex when both sides are visible.
class PieceBuilder {
 public:
  PieceBuilder(const VisibilityParams& params, std::vector<VisiblePolyline>& out)
      : params_(params), out_(out) {}

  void Add(const SweptSegment& s, double from_m, double length_m, double ta, double tb) {
    const Point2 pa = s.a + ta * (s.b - s.a), pb = s.a + tb * (s.b - s.a);
    const bool continues = open_ && current_.source == s.polyline && s.segment == last_segment_ + 1 &&
                           last_t_ >= 1.0 - 1e-9 && ta <= 1e-9;
    if (!continues) {
      Close();
      current_ = VisiblePolyline{{pa}, s.polyline, from_m + ta * length_m, 0.0, false};
      open_ = true;
    }
    current_.points_sensor.push_back(pb);
    current_.source_to_m = from_m + tb * length_m;
    last_segment_ = s.segment;
    last_t_ = tb;
  }

  void Close() {
    if (!open_) return;
    open_ = false;
    if (PolylineLength(current_.points_sensor) < params_.min_piece_length_m) return;
    if (TurnedBearing(current_.points_sensor) < 0.0) {
      std::reverse(current_.points_sensor.begin(), current_.points_sensor.end());
      current_.reversed = true;
    }
    out_.push_back(std::move(current_));
  }

 private:
  const VisibilityParams& params_;
  std::vector<VisiblePolyline>& out_;
  VisiblePolyline current_;
  bool open_ = false;
  std::uint32_t last_segment_ = 0;
  double last_t_ = 0.0;
};

}  // namespace

void VisibilityParams::Validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("VisibilityParams::") + name + " must be > 0");
    }
  };
  positive(max_range_m, "max_range_m");
  positive(fov_rad, "fov_rad");
  positive(angular_resolution_rad, "angular_resolution_rad");
  if (!(min_piece_length_m >= 0.0) || !(depth_tolerance_m >= 0.0)) {
    throw std::invalid_argument(
        "VisibilityParams::min_piece_length_m and depth_tolerance_m must be >= 0");
  }
  if (angular_resolution_rad > fov_rad) {
    throw std::invalid_argument("VisibilityParams::angular_resolution_rad exceeds fov_rad");
  }
}

std::vector<VisiblePolyline> ComputeVisibleShape(
    const std::unordered_map<PolylineId, Polyline>& polylines_map, const SegmentIndex& index,
    const Pose2& T_map_sensor, const VisibilityParams& params, const SeenRays* seen) {
  params.Validate();
  const Sweep& sweep = MakeSweep(params);
  const std::vector<SweptSegment> segments =
      GatherSegments(polylines_map, index, T_map_sensor, params, sweep);
  SegmentBinParts bin_parts = BinPartsOf(sweep, segments);
  if (seen != nullptr) DropSeenThrough(sweep, segments, *seen, bin_parts);
  const std::vector<double> zbuffer = BuildZBuffer(sweep, segments, bin_parts);
  std::vector<VisiblePolyline> out;
  PieceBuilder builder(params, out);
  PolylineId cumulative_of = 0;
  std::vector<double> cumulative;  // arc length at each vertex of the current source polyline
  Intervals scratch, visible;
  for (std::size_t n = 0; n < segments.size(); ++n) {  // sorted by polyline, then segment
    const SweptSegment& s = segments[n];
    if (cumulative.empty() || cumulative_of != s.polyline) {
      const Polyline& p = polylines_map.at(s.polyline);
      cumulative.assign(1, 0.0);
      for (std::size_t i = 0; i + 1 < p.size(); ++i) cumulative.push_back(cumulative.back() + (p[i + 1] - p[i]).norm());
      cumulative_of = s.polyline;
    }
    const double length = (s.b - s.a).norm();
    VisibleIntervals(sweep, s, bin_parts.parts.data() + bin_parts.begin[n], zbuffer,
                     params.depth_tolerance_m, scratch, visible);
    for (const auto& [ta, tb] : visible) {
      builder.Add(s, cumulative[s.segment], length, ta, tb);
    }
  }
  builder.Close();
  // In bearing order of the first points (each bearing computed once; ties keep their order).
  std::vector<std::pair<double, std::size_t>> order(out.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const Point2& p = out[i].points_sensor.front();
    order[i] = {sweep.Offset(std::atan2(p.y(), p.x())), i};
  }
  std::sort(order.begin(), order.end());
  std::vector<VisiblePolyline> sorted;
  sorted.reserve(out.size());
  for (const auto& [bearing, i] : order) sorted.push_back(std::move(out[i]));
  return sorted;
}

SeenRays SeenRaysOf(const LaserScan& scan, double margin_m) {
  SeenRays seen;
  seen.margin_m = margin_m;
  seen.bearings_rad = scan.angles_rad;
  seen.ranges_m.reserve(scan.ranges_m.size());
  for (const double r : scan.ranges_m) {
    const bool reading = std::isfinite(r) && r > 0.0 && r < scan.max_range_m;
    seen.ranges_m.push_back(reading ? r : std::numeric_limits<double>::quiet_NaN());
  }
  return seen;
}

VisibilityParams VisibilityForScan(const LaserScan& scan, const VisibilityParams& base,
                                   double min_range_m, double fov_margin_rad) {
  double farthest = 0.0;
  for (const double r : scan.ranges_m) {
    if (std::isfinite(r) && r > min_range_m && r < scan.max_range_m) farthest = std::max(farthest, r);
  }
  double fov = 0.0;
  const std::size_t n = scan.angles_rad.size();
  if (n >= 2) {
    const double span = scan.angles_rad.back() - scan.angles_rad.front();
    fov = span + span / (n - 1);
  }
  VisibilityParams visibility = base;
  visibility.max_range_m = std::max(1.0, std::min(visibility.max_range_m, farthest + 1.0));
  visibility.fov_rad = std::min(2.0 * M_PI, fov + 2.0 * fov_margin_rad);
  return visibility;
}

}  // namespace shape_slam
