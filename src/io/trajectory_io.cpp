#include "shape_slam_io/trajectory_io.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "shape_slam_io/json_writer.h"

namespace shape_slam::io {
namespace {

// Calls `parse(fields, where)` for every non-comment, non-blank line of a text file.
template <typename Parse>
void ForEachLine(const std::string& path, Parse parse) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw TrajectoryFileError(path + ": is a directory");
  std::ifstream in(path);
  if (!in) throw TrajectoryFileError(path + ": cannot open the file");
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    std::istringstream stream(line);
    std::vector<double> fields;
    const std::string where = path + ":" + std::to_string(number);
    for (std::string f; stream >> f;) {
      errno = 0;
      char* end = nullptr;
      const double v = std::strtod(f.c_str(), &end);
      if (*end != '\0' || errno == ERANGE || !std::isfinite(v)) {
        throw TrajectoryFileError(where + ": '" + f + "' is not a finite number");
      }
      fields.push_back(v);
    }
    parse(fields, where);
  }
  if (in.bad()) throw TrajectoryFileError(path + ": read error");
}

}  // namespace

std::string FormatTum(const std::vector<StampedPose>& trajectory) {
  std::string out = "# timestamp x y z qx qy qz qw\n";
  for (const StampedPose& p : trajectory) {
    const double half = p.pose.theta / 2.0;
    out += FormatDouble(p.timestamp_s) + ' ' + FormatDouble(p.pose.x) + ' ' +
           FormatDouble(p.pose.y) + " 0 0 0 " + FormatDouble(std::sin(half)) + ' ' +
           FormatDouble(std::cos(half)) + '\n';
  }
  return out;
}

std::vector<StampedPose> ReadTrajectory(const std::string& path) {
  std::vector<StampedPose> poses;
  ForEachLine(path, [&](const std::vector<double>& f, const std::string& where) {
    if (f.size() == 4) {
      poses.push_back({f[0], Pose2(f[1], f[2], f[3])});
    } else if (f.size() == 8) {
      const double qx = f[4], qy = f[5], qz = f[6], qw = f[7];
      const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
      if (norm < 1e-9 || std::abs(qx) / norm > 1e-3 || std::abs(qy) / norm > 1e-3) {
        throw TrajectoryFileError(where + ": the quaternion is not a rotation about z");
      }
      poses.push_back({f[0], Pose2(f[1], f[2], NormalizeAngle(2.0 * std::atan2(qz, qw)))});
    } else {
      throw TrajectoryFileError(where + ": expected 4 fields (t x y theta) or 8 (TUM), found " +
                                std::to_string(f.size()));
    }
  });
  if (poses.empty()) throw TrajectoryFileError(path + ": no poses");
  return poses;
}

std::vector<Relation> ReadRelations(const std::string& path) {
  std::vector<Relation> relations;
  ForEachLine(path, [&](const std::vector<double>& f, const std::string& where) {
    if (f.size() != 8) {
      throw TrajectoryFileError(where + ": expected 't1 t2 x y z roll pitch yaw', found " +
                                std::to_string(f.size()) + " fields");
    }
    if (std::abs(f[4]) > 1e-9 || std::abs(f[5]) > 1e-9 || std::abs(f[6]) > 1e-9) {
      throw TrajectoryFileError(where + ": z, roll and pitch must be 0 for a planar relation");
    }
    relations.push_back({f[0], f[1], Pose2(f[2], f[3], f[7])});
  });
  return relations;
}

}  // namespace shape_slam::io
