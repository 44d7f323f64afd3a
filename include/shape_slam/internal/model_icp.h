// Internal (not installed): a fast, unrestricted point-to-point ICP of scan samples against a set
// of model polylines, and the inlier ratio that scores a pose. Used to finish rough estimates
// (the seeds of §4.3, the candidates of the pipeline) before the one Ceres refinement.
#pragma once

#include <optional>
#include <vector>

#include "shape_slam/internal/model_segments.h"
#include "shape_slam/types.h"

namespace shape_slam::internal {

class ModelIcp {
 public:
  /// capture_m: association gate of the first ICP step (it shrinks to 40% of it); inlier_m:
  /// the distance within which a sample counts as explained. Both > 0. open_end_m > 0 prepares
  /// KnownInlierRatio (CandidateSelectionParams::open_end_m).
  ModelIcp(const std::vector<Polyline>& model, double capture_m, double inlier_m,
           double open_end_m = 0.0);

  /// `iterations` point-to-point steps (closed form) from T_model_scan with a shrinking gate;
  /// samples projecting beyond an open end of a model polyline are not used.
  Pose2 Align(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan,
              int iterations) const;

  /// Fraction of the samples within inlier_m of the model at T_model_scan (0 when empty).
  double InlierRatio(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan) const;

  /// InlierRatio over the samples in known space: a sample off the model that continues a model
  /// polyline past an open end (within inlier_m of the end segment's line, at most open_end_m
  /// beyond the end) is left out. InlierRatio when constructed without open_end_m.
  double KnownInlierRatio(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan) const;

 private:
  // The model's segments are made once and copied into each grid.
  ModelIcp(const std::vector<ModelSegment>& segments, double capture_m, double inlier_m,
           double open_end_m);

  SegmentGrid capture_grid_;
  SegmentGrid inlier_grid_;
  std::optional<SegmentGrid> open_end_grid_;
  double capture_m_;
  double inlier_m_;
};

}  // namespace shape_slam::internal
