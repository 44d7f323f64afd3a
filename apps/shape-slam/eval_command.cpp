// shape-slam eval: ATE and Kümmerle relation errors of a trajectory against reference poses.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <utility>

#include "cli.h"
#include "commands.h"
#include "shape_slam/evaluation.h"
#include "shape_slam_io/json_writer.h"
#include "shape_slam_io/trajectory_io.h"

namespace shape_slam::app {
namespace {

ArgParser MakeParser() {
  ArgParser parser(
      "eval",
      "Evaluates an estimated trajectory against reference poses, as defined in\n"
      "datasets/radish/README.md: ATE = RMSE of positions after the best rigid 2D alignment;\n"
      "relation errors (Kümmerle et al. 2009) = mean absolute translation (m) and rotation (deg)\n"
      "of (x_t1^-1 (+) x_t2) (-) reference, for consecutive-scan relations (local) and the rest\n"
      "(revisits). Poses are associated by timestamp. Gross local errors: the steps between\n"
      "consecutive poses of TRAJ (both with a reference pose) whose motion is off the\n"
      "reference's by more than --gross-m or --gross-deg: the tracking failures a mean hides.");
  parser.Positional("TRAJ", "estimated trajectory: TUM or 't x y theta' lines")
      .Positional("GT", "reference trajectory: TUM or 't x y theta' lines")
      .Positional("RELATIONS", "relations file 't1 t2 x y z roll pitch yaw'", false)
      .Option("--max-dt", {"S"}, "largest timestamp difference for associating poses, seconds",
              "0.001")
      .Option("--gross-m", {"M"}, "gross local error: a step off by more than this, metres", "0.5")
      .Option("--gross-deg", {"DEG"}, "gross local error: a step off by more than this, degrees",
              "10")
      .Flag("--list-gross", "also list each gross local error: its poses, both motions, the error")
      .Flag("--json", "print one JSON object");
  return parser;
}

void RelationJson(io::JsonWriter& json, const char* key, const RelationErrors& e) {
  json.Key(key).BeginObject().Key("count").Value(e.count).Key("missing").Value(e.missing);
  json.Key("trans_m").Value(e.mean_translation_m).Key("rot_deg").Value(e.mean_rotation_deg);
  json.EndObject();
}

// The error of a gross step (GrossStep::Error): translation (m) and rotation (deg).
std::pair<double, double> StepError(const GrossStep& g) {
  const Pose2 e = g.Error();
  return {e.Translation().norm(), std::abs(e.theta) * 180.0 / M_PI};
}

void PoseJson(io::JsonWriter& json, const char* key, const Pose2& p) {
  json.Key(key).BeginArray().Value(p.x).Value(p.y).Value(p.theta).EndArray();
}

std::string Json(const EvaluationResult& r, bool list_gross) {
  io::JsonWriter json;
  json.BeginObject().Key("matched_poses").Value(r.matched_poses);
  json.Key("reference_poses").Value(r.reference_poses);
  json.Key("ate_m").Value(r.ate_rmse_m).Key("ate_max_m").Value(r.ate_max_m);
  RelationJson(json, "local", r.local);
  RelationJson(json, "revisit", r.revisit);
  json.Key("gross_local").BeginObject().Key("count").Value(r.gross_local.count);
  json.Key("steps").Value(r.gross_local.steps);
  if (list_gross) {
    json.Key("list").BeginArray();
    for (const GrossStep& g : r.gross_local.listed) {
      const auto [m, deg] = StepError(g);
      json.BeginObject().Key("index").Value(g.index).Key("t1").Value(g.t1_s).Key("t2").Value(g.t2_s);
      PoseJson(json, "estimated", g.estimated);
      PoseJson(json, "reference", g.reference);
      json.Key("error_m").Value(m).Key("error_deg").Value(deg).EndObject();
    }
    json.EndArray();
  }
  json.EndObject();
  json.EndObject();
  return json.str() + "\n";
}

std::string Text(const EvaluationResult& r, bool have_relations, const EvaluationParams& params,
                 bool list_gross) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(4) << "poses matched   " << r.matched_poses << " of "
      << r.reference_poses << " reference poses\n"
      << "ATE (RMSE)      " << r.ate_rmse_m << " m (max " << r.ate_max_m << " m)\n";
  if (have_relations) {
    auto line = [&](const char* name, const RelationErrors& e) {
      out << name << e.mean_translation_m << " m, " << e.mean_rotation_deg << " deg  (" << e.count
          << " relations" << (e.missing ? ", " + std::to_string(e.missing) + " missing" : "")
          << ")\n";
    };
    line("local relations ", r.local);
    line("revisit rel.    ", r.revisit);
  }
  out << std::defaultfloat << "gross local err " << r.gross_local.count << " of "
      << r.gross_local.steps << " steps (off by > " << params.gross_translation_m << " m or > "
      << params.gross_rotation_deg << " deg)\n";
  if (list_gross) {
    const auto motion = [](const Pose2& p) {
      std::ostringstream m;
      m << std::fixed << std::setprecision(3) << p.x << " " << p.y << " " << std::setprecision(1)
        << p.theta * 180.0 / M_PI << " deg";
      return m.str();
    };
    for (const GrossStep& g : r.gross_local.listed) {
      const auto [m, deg] = StepError(g);
      out << std::fixed << std::setprecision(3) << "  pose " << g.index - 1 << " -> " << g.index
          << " (t " << g.t1_s << " -> " << g.t2_s << "): moved " << motion(g.estimated)
          << ", reference " << motion(g.reference) << ", off by " << m << " m "
          << std::setprecision(1) << deg << " deg\n";
    }
  }
  return out.str();
}

}  // namespace

int RunEval(const Args& args) {
  ArgParser parser = MakeParser();
  if (!parser.Parse(args)) {
    std::cout << parser.Help();
    return 0;
  }
  EvaluationParams params;
  params.max_time_difference_s = parser.GetDouble("--max-dt", params.max_time_difference_s);
  if (params.max_time_difference_s < 0) throw UsageError("--max-dt must be >= 0");
  params.gross_translation_m = parser.GetDouble("--gross-m", params.gross_translation_m);
  params.gross_rotation_deg = parser.GetDouble("--gross-deg", params.gross_rotation_deg);
  if (!(params.gross_translation_m >= 0)) throw UsageError("--gross-m must be >= 0");
  if (!(params.gross_rotation_deg >= 0)) throw UsageError("--gross-deg must be >= 0");
  const std::vector<StampedPose> estimate = io::ReadTrajectory(parser.Get("TRAJ"));
  const std::vector<StampedPose> reference = io::ReadTrajectory(parser.Get("GT"));
  std::vector<Relation> relations;
  if (const auto path = parser.GetOptional("RELATIONS")) relations = io::ReadRelations(*path);
  const EvaluationResult result = EvaluateTrajectory(estimate, reference, relations, params);
  // Scores over a small part of the reference say little about the trajectory as a whole.
  constexpr double kMinAssociatedFraction = 0.9;
  if (result.matched_poses < kMinAssociatedFraction * result.reference_poses) {
    std::cerr << "warning: only " << result.matched_poses << " of " << result.reference_poses
              << " reference poses were associated with the trajectory (timestamps within "
              << params.max_time_difference_s << " s): the figures cover only those\n";
  }
  const bool list_gross = parser.Has("--list-gross");
  std::cout << (parser.Has("--json") ? Json(result, list_gross)
                                     : Text(result, !relations.empty(), params, list_gross));
  return 0;
}

}  // namespace shape_slam::app
