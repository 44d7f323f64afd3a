// Internal (not installed): the building blocks of registering a scan against a model, shared
// by every stage that does it -- per-scan tracking (internal/localization.h), loop closure
// (loop_closure.h), scan-to-scan matching (scan_matcher.h) and the localizer (localizer.h).
// The scan enters as samples of its alignment polylines (§5.1, 10 cm apart), the model as
// polylines; nothing here knows the mapper, so these stages include this header, not
// pipeline.h.
#pragma once

#include <optional>
#include <vector>

#include "shape_slam/alignment_refinement.h"
#include "shape_slam/internal/model_segments.h"
#include "shape_slam/types.h"

namespace shape_slam::internal {

/// Samples of the alignment polylines every spacing_m (§5.1).
std::vector<Point2> AlignmentSamples(const std::vector<Polyline>& fine, double spacing_m);

/// Every k-th sample, k = to_m / from_m: samples spaced from_m apart thinned to about to_m.
std::vector<Point2> Thinned(const std::vector<Point2>& samples, double from_m, double to_m);

/// Refines an estimate against every model polyline: with a wide gate first (coarse_gate_m, for
/// odometry-size errors), then with the configured one.
RefinementResult RefineAgainstMap(const std::vector<Point2>& samples,
                                  const std::vector<Polyline>& model, const Pose2& init,
                                  const std::optional<PosePrior>& prior,
                                  const RefinementParams& refinement, double coarse_gate_m);

/// Fraction of the samples within the grid's radius of the model at an estimate.
double InlierRatio(const std::vector<Point2>& samples, const SegmentGrid& grid,
                   const Pose2& T_model_scan);

}  // namespace shape_slam::internal
