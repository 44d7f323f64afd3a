// The turn between two laser scans from the directions of their surfaces (not in the paper).
//
// Method: each scan's histogram of surface directions, from the segments of its polylines (§3.1:
// the scan's points grouped where they lie closer than 20 cm, simplified by DCE, so a straight
// wall is one segment and the beams' noise averages out; undirected, so over [0, pi); weighted
// by length), smoothed by one bin on each side. (From the segments between neighbouring beam
// points instead, 1 cm of range noise turned the turn found in a simulated room by up to 0.05
// rad.) A turn of the sensor by t shifts every direction it sees by -t, so the turn is the
// shift that correlates the two histograms best, within +-max_turn_rad (refined between bins by a
// parabola through the peak). Needs no pose guess and no correspondence; a corridor or a room
// gives a clear peak, clutter a weaker one. What it cannot give is the translation.
#pragma once

#include <optional>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

struct OrientationHistogramParams {
  double bin_rad = 0.5 * M_PI / 180.0;  ///< histogram bin width
  double max_turn_rad = 0.8;            ///< turns searched: [-max_turn_rad, max_turn_rad]
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// Surface directions of a scan (sensor frame), length per bin over [0, pi).
struct OrientationHistogram {
  std::vector<double> bins;
  double total_m = 0.0;  ///< the length of all segments counted
};

/// The histogram of a scan's polylines (sensor frame; ScanShapes::fine).
OrientationHistogram ComputeOrientationHistogram(const std::vector<Polyline>& polylines,
                                                 const OrientationHistogramParams& params);

/// The turn of the sensor from the scan of `before` to that of `after` (counter-clockwise
/// positive, radians); nullopt when either histogram is empty or they differ in size.
std::optional<double> HistogramTurn(const OrientationHistogram& before,
                                    const OrientationHistogram& after,
                                    const OrientationHistogramParams& params);

}  // namespace shape_slam
