// Trajectory and relation files: TUM (`timestamp x y z qx qy qz qw`, what evo and similar tools
// read), the planar `timestamp x y theta` of the reference poses, and Kümmerle relations
// (`t1 t2 x y z roll pitch yaw`).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "shape_slam/evaluation.h"

namespace shape_slam::io {

/// A trajectory or relations file that cannot be read; what() names the file and line.
class TrajectoryFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// TUM text of a planar trajectory: z = 0, yaw as a unit quaternion about z, timestamps
/// written in the shortest form that reads back to the same double.
std::string FormatTum(const std::vector<StampedPose>& trajectory);

/// Reads a trajectory, one pose per line, in either layout, detected per line by its field
/// count: 8 fields (TUM: yaw taken from the quaternion; a quaternion that is not a rotation
/// about z is an error) or 4 fields (`t x y theta`). '#' starts a comment.
std::vector<StampedPose> ReadTrajectory(const std::string& path);

/// Reads Kümmerle relations; only x, y and yaw are used (z, roll, pitch must be 0).
std::vector<Relation> ReadRelations(const std::string& path);

}  // namespace shape_slam::io
