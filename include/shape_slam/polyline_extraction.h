// Grouping of scan points into polylines (paper §3.1).
//
// Traversing the reflection points in the order the scanner measured them, an object
// transition is present wherever two consecutive points are farther apart than a distance
// threshold (the paper uses 20 cm; we widen it with the range, see gap_beam_spacing_factor) --
// and wherever a beam gave no usable reading.
#pragma once

#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

struct ExtractionParams {
  /// Consecutive points farther apart than this start a new polyline, metres (§3.1: 0.20) ...
  double max_gap_m = 0.20;
  /// ... or, if larger, than this many times the beams' spacing at the nearer point's range
  /// (range * angle between the beams). Beyond 10 m or so a 1 deg scanner's points on a wall lie
  /// farther apart than 20 cm: a fixed threshold breaks the far walls, which are what tells a
  /// robot where it is along a corridor, into single points that carry no shape. 0: off.
  double gap_beam_spacing_factor = 2.5;
  /// Readings at or below this range are invalid, metres.
  double min_range_m = 0.02;
  /// Polylines with fewer points are dropped (isolated returns carry no shape).
  int min_points = 2;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// The scan's points grouped into polylines, in the SENSOR frame, in beam order. A beam is
/// invalid (and splits) when its range is not finite, <= min_range_m or >= the scan's
/// max_range_m. For a scan covering 360 deg (span of the beam angles plus one beam step
/// >= 2 pi - 1e-6) the order is cyclic: the last and the first group are joined across the
/// seam when no split separates them. Throws std::invalid_argument when ranges and angles
/// differ in size or the params are invalid.
std::vector<Polyline> ExtractPolylines(const LaserScan& scan, const ExtractionParams& params);

/// The scan with its beams in increasing angle (reversed when they run clockwise), so that its
/// polylines run counter-clockwise like the visible map shape (§3: both are ordered
/// counter-clockwise).
LaserScan CounterClockwiseScan(const LaserScan& scan);

}  // namespace shape_slam
