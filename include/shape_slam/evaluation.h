// Trajectory accuracy metrics, as defined in datasets/radish/README.md: the absolute trajectory
// error (ATE) after the best rigid 2D alignment, and the relation errors of Kümmerle et al.
// (2009), "On measuring the accuracy of SLAM algorithms", split into consecutive-scan
// relations (local accuracy) and the rest (revisits: global consistency).
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

struct StampedPose {
  double timestamp_s = 0.0;
  Pose2 pose;
};

/// A relation: the reference motion from the pose at t1 to the pose at t2, in the frame of t1.
struct Relation {
  double t1_s = 0.0;
  double t2_s = 0.0;
  Pose2 T_1_2;
};

struct EvaluationParams {
  /// Poses are associated by timestamp when they differ by at most this, seconds.
  double max_time_difference_s = 1e-3;
  /// A step between consecutive poses is a gross local error when its motion differs from the
  /// reference's by more than this translation, metres ...
  double gross_translation_m = 0.5;
  /// ... or by more than this rotation, degrees.
  double gross_rotation_deg = 10.0;
  void Validate() const;
};

struct RelationErrors {
  std::size_t count = 0;          ///< relations evaluated (both poses found)
  std::size_t missing = 0;        ///< relations whose poses were not in the estimate
  double mean_translation_m = 0;  ///< mean absolute translation error
  double mean_rotation_deg = 0;   ///< mean absolute rotation error
};

/// One gross local error: the step from estimate pose `index - 1` to pose `index`.
struct GrossStep {
  /// The step's second pose, counted from 0 in the estimate's time order (for a trajectory
  /// written one pose per scan in time order, as `run` writes it: the scan's index).
  std::size_t index = 0;
  double t1_s = 0.0;      ///< timestamps of the step's two estimate poses
  double t2_s = 0.0;
  Pose2 estimated;        ///< the estimate's motion, in the frame of its first pose
  Pose2 reference;        ///< the reference's motion between the associated reference poses
  /// How far the estimate's motion is off the reference's: reference^-1 * estimated.
  Pose2 Error() const { return reference.Inverse() * estimated; }
};

/// Tracking failures that a mean hides: steps between consecutive estimate poses (both with a
/// reference pose) whose motion is off the reference motion by more than the thresholds.
struct GrossLocalErrors {
  std::size_t steps = 0;  ///< consecutive estimate pose pairs that both have a reference pose
  std::size_t count = 0;  ///< of those, the steps off by > gross_translation_m or _rotation_deg
  std::vector<GrossStep> listed;  ///< those steps, in time order (count of them)
};

struct EvaluationResult {
  std::size_t matched_poses = 0;  ///< estimate poses associated with a reference pose
  std::size_t reference_poses = 0;
  double ate_rmse_m = 0.0;        ///< after the best rigid alignment
  double ate_max_m = 0.0;
  Pose2 T_reference_estimate;     ///< that alignment
  RelationErrors local;           ///< t2 is the reference pose right after t1
  RelationErrors revisit;         ///< all other relations
  GrossLocalErrors gross_local;   ///< consecutive estimate poses, against the reference poses
};

/// Best rigid transform (no scale) mapping `from` onto `to` in the least-squares sense.
/// Precondition: equal sizes, at least one point.
Pose2 BestRigidAlignment(const std::vector<Point2>& from, const std::vector<Point2>& to);

/// Evaluates `estimate` against `reference` (and `relations`, may be empty). Throws
/// std::invalid_argument when no estimate pose can be associated with the reference.
EvaluationResult EvaluateTrajectory(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& reference,
                                    const std::vector<Relation>& relations,
                                    const EvaluationParams& params = {});

}  // namespace shape_slam
