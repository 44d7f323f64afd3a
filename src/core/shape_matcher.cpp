#include "shape_slam/shape_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>

#include "shape_slam/geometry.h"
#include "shape_slam/evaluation.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/internal/prepared_shape.h"

namespace shape_slam {
namespace {

// A sample of a perceived polyline with the direction of its segment.
struct DirectedSample {
  Point2 point;
  Point2 direction;  // unit vector
};

constexpr double kMaxDeviationSamplesPerSegment = 1000.0;

// Samples at the centres of equal pieces of every segment (at least one per segment).
std::vector<DirectedSample> SampleWithDirections(const Polyline& polyline, double spacing_m) {
  std::vector<DirectedSample> samples;
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    const Point2 d = polyline[i + 1] - polyline[i];
    const double length = d.norm();
    if (length <= 0.0) continue;
    // At most kMaxDeviationSamplesPerSegment per segment: a group joins neighbouring polylines
    // by the segments between them, which can be arbitrarily long (far-apart objects).
    const int n = static_cast<int>(std::clamp(std::ceil(length / spacing_m), 1.0,
                                              kMaxDeviationSamplesPerSegment));
    for (int k = 0; k < n; ++k) {
      samples.push_back({polyline[i] + d * ((k + 0.5) / n), d / length});
    }
  }
  return samples;
}

Polyline Concatenate(const std::vector<Polyline>& polylines, int first, int count) {
  Polyline out;
  const int n = static_cast<int>(polylines.size());
  for (int k = 0; k < count; ++k) {
    const Polyline& p = polylines[(first + k) % n];
    out.insert(out.end(), p.begin(), p.end());
  }
  return out;
}

// How well the estimate lays a perceived polyline onto a model polyline, over their overlap.
struct Misfit {
  double rms_m = 0.0;
  double angle_rms_rad = 0.0;
  double overlap_m = 0.0;
};

// Stops early, with rms_m = +inf, once the sums alone put the RMS distance above max_rms_m or
// the RMS angle above max_angle_rad whatever the samples left (at most all of them overlap):
// the caller refuses such a pair either way. The 1e-6 margin keeps that certain under rounding.
Misfit MeasureMisfit(const std::vector<DirectedSample>& samples_scan, double perceived_length_m,
                     const Polyline& model, const Pose2& T_model_scan, double max_rms_m,
                     double max_angle_rad) {
  Misfit misfit;
  if (samples_scan.empty() || model.size() < 2) return misfit;
  const PointTransform transform(T_model_scan);
  const Eigen::Matrix2d& R = transform.Rotation();
  double sum_d2 = 0.0, sum_a2 = 0.0;
  int overlapping = 0;
  const std::size_t last_segment = model.size() - 2;
  const double n = static_cast<double>(samples_scan.size()) * (1.0 + 1e-6);
  const double max_sum_d2 = max_rms_m * max_rms_m * n;
  const double max_sum_a2 = max_angle_rad * max_angle_rad * n;
  for (const DirectedSample& s : samples_scan) {
    const PolylineProjection proj = ProjectOntoPolyline(transform(s.point), model);
    const bool at_open_end = (proj.segment == 0 && proj.t <= 0.0) ||
                             (proj.segment == last_segment && proj.t >= 1.0);
    if (at_open_end) continue;
    const Point2 model_dir = model[proj.segment + 1] - model[proj.segment];
    const Point2 dir = R * s.direction;
    const double angle = std::atan2(dir.x() * model_dir.y() - dir.y() * model_dir.x(),
                                    dir.dot(model_dir));
    sum_d2 += proj.squared_distance;
    sum_a2 += angle * angle;
    ++overlapping;
    if (sum_d2 > max_sum_d2 || sum_a2 > max_sum_a2) {
      misfit.rms_m = std::numeric_limits<double>::infinity();
      return misfit;
    }
  }
  if (overlapping == 0) return misfit;
  misfit.rms_m = std::sqrt(sum_d2 / overlapping);
  misfit.angle_rms_rad = std::sqrt(sum_a2 / overlapping);
  misfit.overlap_m = perceived_length_m * overlapping / samples_scan.size();
  return misfit;
}

// A group of consecutive polylines joined into one, with what the costs need of it.
struct Group {
  Polyline points;
  double length_m = 0.0;
  Point2 min = Point2::Zero(), max = Point2::Zero();  // bounding box
  std::vector<DirectedSample> samples;                // for D (scan groups only)
};

// Group polylines and S* values, computed once per group (pair) and shared by all passes and
// seeds (S* does not depend on the pose estimate). Flat arrays indexed by (first, count).
class PairEvaluator {
 public:
  PairEvaluator(const ShapeMatchInput& input, const ShapeMatcherParams& params)
      : input_(input),
        params_(params),
        g_(std::max(params.max_group_size, params.first_pass_group_size)),
        a_(static_cast<int>(input.scan.size())),
        b_(static_cast<int>(input.model.size())),
        scan_groups_(static_cast<std::size_t>(a_) * g_),
        model_groups_(static_cast<std::size_t>(b_) * g_),
        scan_stages_(scan_groups_.size()),
        model_shapes_(model_groups_.size()),
        s_star_(static_cast<std::size_t>(a_) * g_ * b_ * g_,
                std::numeric_limits<double>::quiet_NaN()) {}

  const Group& ScanGroup(int first, int count) {
    return Get(scan_groups_, input_.scan, first, count, true);
  }
  const Group& ModelGroup(int first, int count) {
    return Get(model_groups_, input_.model, first, count, false);
  }

  // S*(scan group, model group) of ComputeEvolvedSimilarity, each group prepared once
  // (internal/prepared_shape.h): the scan group's DCE stages and the model group's arcs serve
  // every pair they are in.
  double SStar(int i, int gs, int j, int gm) {
    double& slot = s_star_[((static_cast<std::size_t>(i) * g_ + gs - 1) * b_ + j) * g_ + gm - 1];
    if (std::isnan(slot)) {
      std::unique_ptr<internal::EvolutionStages>& stages =
          scan_stages_[static_cast<std::size_t>(i) * g_ + gs - 1];
      if (!stages) stages = std::make_unique<internal::EvolutionStages>(ScanGroup(i, gs).points);
      std::unique_ptr<internal::PreparedShape>& model =
          model_shapes_[static_cast<std::size_t>(j) * g_ + gm - 1];
      if (!model) model = std::make_unique<internal::PreparedShape>(ModelGroup(j, gm).points);
      slot = internal::EvolvedSimilarityValue(*stages, *model, params_.similarity, dp_);
    }
    return slot;
  }

  // D of eq. (4) against an estimate, or nullopt when a gate rejects the pair.
  std::optional<double> Deviation(int i, int gs, int j, int gm, const Pose2& T_model_scan,
                                  double max_misfit_m) {
    const Group& scan = ScanGroup(i, gs);
    const Group& model = ModelGroup(j, gm);
    if (!BoxesMeet(scan, model, T_model_scan, max_misfit_m)) return std::nullopt;  // cheap first
    const Misfit m = MeasureMisfit(scan.samples, scan.length_m, model.points, T_model_scan,
                                   max_misfit_m, params_.max_angle_rad);
    const double shorter = std::min(scan.length_m, model.length_m);
    if (m.overlap_m <= 0.0 || m.overlap_m < params_.min_overlap_fraction * shorter ||
        m.rms_m > max_misfit_m || m.angle_rms_rad > params_.max_angle_rad) {
      return std::nullopt;
    }
    const double dt = m.rms_m / params_.deviation_sigma_m;
    const double dr = m.angle_rms_rad / params_.deviation_sigma_rad;
    return params_.deviation_weight * (dt * dt + dr * dr);
  }

 private:
  const Group& Get(std::vector<std::optional<Group>>& cache, const std::vector<Polyline>& polylines,
                   int first, int count, bool with_samples) {
    std::optional<Group>& slot = cache[static_cast<std::size_t>(first) * g_ + count - 1];
    if (!slot) {
      Group group;
      group.points = Concatenate(polylines, first, count);
      group.length_m = PolylineLength(group.points);
      group.min = group.max = group.points.empty() ? Point2::Zero() : group.points.front();
      for (const Point2& p : group.points) group.min = group.min.cwiseMin(p), group.max = group.max.cwiseMax(p);
      if (with_samples) {
        group.samples = SampleWithDirections(group.points, params_.deviation_sample_spacing_m);
      }
      slot = std::move(group);
    }
    return *slot;
  }

  // Whether the scan group, moved by the estimate, comes within max_misfit_m of the model
  // group's bounding box.
  bool BoxesMeet(const Group& scan, const Group& model, const Pose2& T, double margin) const {
    Point2 lo = Point2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (const Point2& corner : {scan.min, scan.max, Point2(scan.min.x(), scan.max.y()),
                                Point2(scan.max.x(), scan.min.y())}) {
      const Point2 q = T * corner;
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    return lo.x() <= model.max.x() + margin && hi.x() >= model.min.x() - margin &&
           lo.y() <= model.max.y() + margin && hi.y() >= model.min.y() - margin;
  }

  const ShapeMatchInput& input_;
  const ShapeMatcherParams& params_;
  int g_, a_, b_;
  std::vector<std::optional<Group>> scan_groups_, model_groups_;
  std::vector<std::unique_ptr<internal::EvolutionStages>> scan_stages_;
  std::vector<std::unique_ptr<internal::PreparedShape>> model_shapes_;
  std::vector<double> s_star_;  // NaN: not computed yet
  std::vector<double> dp_;      // the similarity DP's buffer
};

std::vector<double> SkipPenalties(const std::vector<Polyline>& polylines, double per_m) {
  std::vector<double> penalties;
  penalties.reserve(polylines.size());
  for (const Polyline& p : polylines) penalties.push_back(per_m * PolylineLength(p));
  return penalties;
}

// With an estimate, the cyclic model's order starts near the model polyline whose bearing, seen
// from the scan, is the first at or after the scan's own first polyline: that rotation and its
// neighbours are the only ones worth trying.
std::vector<int> LikelyRotations(const ShapeMatchInput& input, const Pose2& T_model_scan) {
  const int b = static_cast<int>(input.model.size());
  if (b <= 3 || input.scan.empty() || input.scan.front().empty()) return {};
  const Point2& s0 = input.scan.front().front();
  const double start = std::atan2(s0.y(), s0.x()) - 0.5;  // a little before the scan's start
  const Pose2 T_scan_model = T_model_scan.Inverse();
  int best = 0;
  double best_offset = 4.0 * M_PI;
  for (int j = 0; j < b; ++j) {
    if (input.model[j].empty()) continue;
    const Point2 p = T_scan_model * input.model[j].front();
    double offset = std::fmod(std::atan2(p.y(), p.x()) - start, 2.0 * M_PI);
    if (offset < 0.0) offset += 2.0 * M_PI;
    if (offset < best_offset) best_offset = offset, best = j;
  }
  return {(best + b - 1) % b, best, (best + 1) % b};
}

// One pass of eq. (4): with an estimate, cost = S* + D and gated pairs are forbidden; without,
// cost = S* (the first pass of §4.3).
CorrespondenceSolution SolvePass(const ShapeMatchInput& input, const ShapeMatcherParams& params,
                                 PairEvaluator& evaluator, const std::optional<Pose2>& estimate,
                                 int max_group_size, double max_misfit_m) {
  CorrespondenceProblem problem;
  problem.scan_skip_penalty = SkipPenalties(input.scan, params.skip_penalty_per_m);
  problem.model_skip_penalty = SkipPenalties(input.model, params.skip_penalty_per_m);
  problem.model_cyclic = input.model_cyclic;
  if (estimate && input.model_cyclic) problem.model_rotations = LikelyRotations(input, *estimate);
  problem.max_group_size = max_group_size;
  problem.group_cost = [&](int i, int gs, int j, int gm) -> std::optional<double> {
    if (evaluator.ScanGroup(i, gs).points.size() < 2 || evaluator.ModelGroup(j, gm).points.size() < 2) {
      return std::nullopt;  // a single point has no shape
    }
    double deviation = 0.0;
    if (estimate) {
      const std::optional<double> d = evaluator.Deviation(i, gs, j, gm, *estimate, max_misfit_m);
      if (!d) return std::nullopt;  // gated before paying for S*
      deviation = *d;
    }
    return evaluator.SStar(i, gs, j, gm) + deviation;
  };
  return SolveCorrespondence(problem);
}

const std::vector<Polyline>& AlignmentPolylines(const ShapeMatchInput& input) {
  return input.scan_fine.empty() ? input.scan : input.scan_fine;
}

// §5.1: ICP restricted to the matched shapes.
AlignmentResult AlignMatches(const ShapeMatchInput& input, const std::vector<GroupMatch>& matches,
                             const Pose2& T_model_scan_init, const AlignmentParams& params) {
  const std::vector<Polyline>& perceived = AlignmentPolylines(input);
  const int num_model = static_cast<int>(input.model.size());
  std::vector<ShapePair> pairs;
  for (const GroupMatch& m : matches) {
    std::vector<Polyline> model;
    for (int k = 0; k < m.model_count; ++k) model.push_back(input.model[m.ModelIndex(k, num_model)]);
    for (int k = 0; k < m.scan_count; ++k) pairs.push_back({perceived[m.scan_first + k], model, 1.0});
  }
  return AlignShapes(pairs, T_model_scan_init, params);
}

// Scores estimates by the fraction of the scan's samples near the model, and finishes rough ones
// by a few ICP steps against the whole model: the candidate selection (candidate_selection.h)
// with the seed settings, on samples every fit_sample_spacing_m.
class FitScorer {
 public:
  FitScorer(const ShapeMatchInput& input, const ShapeMatcherParams& params)
      : selector_(input.model, SeedSelection(params)) {
    for (const Polyline& polyline : AlignmentPolylines(input)) {
      for (const DirectedSample& s : SampleWithDirections(polyline, params.fit_sample_spacing_m)) {
        samples_.push_back(s.point);
      }
    }
  }
  double InlierRatio(const Pose2& T_model_scan) const { return selector_.Fit(samples_, T_model_scan); }
  Pose2 QuickAlign(const Pose2& T_model_scan) const {
    return selector_.QuickAlign(samples_, T_model_scan, selector_.Params().icp_iterations);
  }

 private:
  static CandidateSelectionParams SeedSelection(const ShapeMatcherParams& params) {
    CandidateSelectionParams selection;
    selection.icp_iterations = params.seed_icp_iterations;
    selection.capture_distance_m = params.seed_capture_distance_m;
    selection.inlier_distance_m = params.inlier_distance_m;
    selection.equally_good_fit = 0.0;  // the fit alone orders the seeds
    return selection;
  }
  CandidateSelector selector_;
  std::vector<Point2> samples_;
};

ShapeMatchResult Finish(const ShapeMatchInput& input, const ShapeMatcherParams& params,
                        const FitScorer& scorer, CorrespondenceSolution solution,
                        const Pose2& T_model_scan_init) {
  ShapeMatchResult result;
  result.alignment = AlignMatches(input, solution.matches, T_model_scan_init, params.alignment);
  result.T_model_scan = solution.matches.empty() ? T_model_scan_init : result.alignment.T_map_scan;
  result.matches = std::move(solution.matches);
  result.total_cost = solution.total_cost;
  result.inlier_ratio = scorer.InlierRatio(result.T_model_scan);
  return result;
}

// A seed of §4.3: a 1-to-1 pair with its reliability Q (eq. 5).
struct Seed {
  int scan = 0, model = 0;
  double reliability = 0.0;
};

// The most reliable correspondences (§4.3, eq. 5). The paper selects among the pairs of the
// first pass's matching; we rank them first and then every other 1-to-1 pair the first pass
// evaluated, because a salient shape may be paired wrongly in the first pass when its
// neighbours are ambiguous. Polylines shorter than min_seed_length_m carry too little shape.
std::vector<Seed> MostReliablePairs(const ShapeMatchInput& input,
                                    const CorrespondenceSolution& first_pass,
                                    const ShapeMatcherParams& params, PairEvaluator& evaluator) {
  std::vector<Seed> chosen, others;
  auto seed_of = [&](int i, int j) {
    return Seed{i, j, Reliability(input.scan[i], input.model[j], evaluator.SStar(i, 1, j, 1))};
  };
  for (const GroupMatch& m : first_pass.matches) {
    if (m.scan_count == 1 && m.model_count == 1) chosen.push_back(seed_of(m.scan_first, m.model_first));
  }
  for (int i = 0; i < static_cast<int>(input.scan.size()); ++i) {
    if (input.scan[i].size() < 2 || PolylineLength(input.scan[i]) < params.min_seed_length_m) continue;
    for (int j = 0; j < static_cast<int>(input.model.size()); ++j) {
      if (input.model[j].size() < 2 || PolylineLength(input.model[j]) < params.min_seed_length_m) continue;
      const bool in_first_pass = std::any_of(chosen.begin(), chosen.end(), [&](const Seed& s) {
        return s.scan == i && s.model == j;
      });
      if (!in_first_pass) others.push_back(seed_of(i, j));
    }
  }
  auto by_reliability = [](const Seed& a, const Seed& b) { return a.reliability > b.reliability; };
  std::stable_sort(chosen.begin(), chosen.end(), by_reliability);
  std::stable_sort(others.begin(), others.end(), by_reliability);
  chosen.insert(chosen.end(), others.begin(), others.end());
  if (static_cast<int>(chosen.size()) > params.max_seed_pairs) chosen.resize(params.max_seed_pairs);
  return chosen;
}

// Candidate estimates of §4.3: the alignments induced by the most reliable pairs, pre-scored by
// their fit so that only the best num_seeds go through the second pass, then the caller's hints.
struct Candidate {
  Pose2 T_model_scan;
  double reliability = std::numeric_limits<double>::quiet_NaN();
  double fit = 0.0;
};

bool SameEstimate(const Pose2& a, const Pose2& b, const ShapeMatcherParams& params) {
  return PosesWithin(a, b, params.same_seed_m, params.same_seed_rad);
}

std::vector<Candidate> SeedCandidates(const ShapeMatchInput& input,
                                      const ShapeMatcherParams& params, PairEvaluator& evaluator,
                                      const FitScorer& scorer) {
  const CorrespondenceSolution first =
      SolvePass(input, params, evaluator, std::nullopt, params.first_pass_group_size, 0.0);
  // Each seed's induced alignment finished by the candidate selection's quick ICP; a seed that
  // lands where an earlier one was finished adds nothing. Best fit first (the most reliable
  // pair first between equal fits), the best num_seeds go on.
  std::vector<Candidate> candidates;
  for (const Seed& seed : MostReliablePairs(input, first, params, evaluator)) {
    AlignmentParams quick = params.alignment;
    quick.max_iterations = std::min(quick.max_iterations, params.seed_alignment_iterations);
    const AlignmentResult induced =
        InducedAlignment(input.scan[seed.scan], input.model[seed.model], quick);
    const bool duplicate = std::any_of(candidates.begin(), candidates.end(), [&](const Candidate& c) {
      return SameEstimate(c.T_model_scan, induced.T_map_scan, params);
    });
    if (duplicate) continue;
    const Pose2 aligned = scorer.QuickAlign(induced.T_map_scan);
    candidates.push_back({aligned, seed.reliability, scorer.InlierRatio(aligned)});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.fit > b.fit; });
  if (static_cast<int>(candidates.size()) > params.num_seeds) candidates.resize(params.num_seeds);
  for (const Pose2& hint : input.hint_estimates) candidates.push_back({hint});
  return candidates;
}

// How a candidate's final fit ranks: its inlier ratio, less a mild penalty on the rotation it
// implies. Symmetric places (a corridor turned by 180 deg fits itself) fit equally well either
// way; between consecutive scans the smaller turn is the likelier one.
double SelectionScore(const ShapeMatchResult& result, const ShapeMatcherParams& params) {
  const double turn = result.T_model_scan.theta / M_PI;
  return result.inlier_ratio - params.rotation_prior_weight * turn * turn;
}

// §4.3: two passes, the second against each candidate estimate; the best final fit wins (see
// SelectionScore, then lowest eq. (4) cost).
ShapeMatchResult MatchWithoutGuess(const ShapeMatchInput& input, const ShapeMatcherParams& params,
                                   PairEvaluator& evaluator, const FitScorer& scorer) {
  std::vector<ShapeMatchResult> results;
  std::vector<double> scores, costs;
  for (const Candidate& candidate : SeedCandidates(input, params, evaluator, scorer)) {
    CorrespondenceSolution second =
        SolvePass(input, params, evaluator, candidate.T_model_scan, params.max_group_size,
                  params.seeded_max_misfit_m);
    results.push_back(Finish(input, params, scorer, std::move(second), candidate.T_model_scan));
    results.back().reliability = candidate.reliability;
    scores.push_back(SelectionScore(results.back(), params));
    costs.push_back(results.back().total_cost);
  }
  if (results.empty()) {
    ShapeMatchResult none;
    none.inlier_ratio = scorer.InlierRatio(none.T_model_scan);
    return none;
  }
  // The candidate selection's order: best score; between equal scores, the lower eq. (4) cost.
  return std::move(results[OrderByFit(scores, costs, 1e-12).front()]);
}

// Points at equal fractions of the arc length of a polyline (both ends included).
std::vector<Point2> EqualArcLengthPoints(const Polyline& polyline, int count) {
  std::vector<Point2> points;
  const double total = PolylineLength(polyline);
  std::size_t segment = 0;
  double walked = 0.0;
  for (int k = 0; k < count; ++k) {
    const double target = total * k / (count - 1);
    while (segment + 2 < polyline.size() &&
           walked + (polyline[segment + 1] - polyline[segment]).norm() < target) {
      walked += (polyline[segment + 1] - polyline[segment]).norm();
      ++segment;
    }
    const Point2 d = polyline[segment + 1] - polyline[segment];
    const double length = d.norm();
    const double t = length > 0.0 ? std::clamp((target - walked) / length, 0.0, 1.0) : 0.0;
    points.push_back(polyline[segment] + t * d);
  }
  return points;
}

}  // namespace

void ShapeMatcherParams::Validate() const {
  similarity.Validate();
  alignment.Validate();
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("ShapeMatcherParams::") + name + " must be > 0");
    }
  };
  positive(skip_penalty_per_m, "skip_penalty_per_m");
  positive(deviation_sigma_m, "deviation_sigma_m");
  positive(deviation_sigma_rad, "deviation_sigma_rad");
  positive(max_misfit_m, "max_misfit_m");
  positive(seeded_max_misfit_m, "seeded_max_misfit_m");
  positive(max_angle_rad, "max_angle_rad");
  positive(inlier_distance_m, "inlier_distance_m");
  positive(deviation_sample_spacing_m, "deviation_sample_spacing_m");
  if (!(deviation_weight >= 0.0) || !std::isfinite(deviation_weight)) {
    throw std::invalid_argument("ShapeMatcherParams::deviation_weight must be >= 0");
  }
  if (!(min_overlap_fraction >= 0.0 && min_overlap_fraction <= 1.0)) {
    throw std::invalid_argument("ShapeMatcherParams::min_overlap_fraction must be in [0, 1]");
  }
  if (max_group_size < 1 || first_pass_group_size < 1) {
    throw std::invalid_argument("ShapeMatcherParams: group sizes must be >= 1");
  }
  if (!(rotation_prior_weight >= 0.0) || !std::isfinite(rotation_prior_weight)) {
    throw std::invalid_argument("ShapeMatcherParams::rotation_prior_weight must be >= 0");
  }
  if (seed_icp_iterations < 0) {
    throw std::invalid_argument("ShapeMatcherParams::seed_icp_iterations must be >= 0");
  }
  positive(seed_capture_distance_m, "seed_capture_distance_m");
  positive(fit_sample_spacing_m, "fit_sample_spacing_m");
  positive(same_seed_m, "same_seed_m");
  positive(same_seed_rad, "same_seed_rad");
  if (seed_alignment_iterations < 1) {
    throw std::invalid_argument("ShapeMatcherParams::seed_alignment_iterations must be >= 1");
  }
  if (num_seeds < 1) throw std::invalid_argument("ShapeMatcherParams::num_seeds must be >= 1");
  if (max_seed_pairs < 1) {
    throw std::invalid_argument("ShapeMatcherParams::max_seed_pairs must be >= 1");
  }
  if (!(min_seed_length_m >= 0.0)) {
    throw std::invalid_argument("ShapeMatcherParams::min_seed_length_m must be >= 0");
  }
}

AlignmentResult InducedAlignment(const Polyline& perceived, const Polyline& model,
                                 const AlignmentParams& params) {
  AlignmentResult best;
  if (perceived.size() < 2 || model.size() < 2) return best;
  constexpr int kPoints = 16;
  const std::vector<Point2> a = EqualArcLengthPoints(perceived, kPoints);
  const std::vector<Point2> b = EqualArcLengthPoints(model, kPoints);
  // Rotation from the equal-arc-length fit; translations aligning start, end and centre.
  const Pose2 fit = BestRigidAlignment(a, b);
  std::vector<Pose2> initial = {fit};
  for (const int k : {0, kPoints - 1, kPoints / 2}) {
    const Point2 t = b[k] - Pose2(0, 0, fit.theta) * a[k];
    initial.emplace_back(t.x(), t.y(), fit.theta);
  }
  const std::vector<ShapePair> pair = {{perceived, {model}, 1.0}};
  bool have = false;
  for (const Pose2& T0 : initial) {
    AlignmentResult r = AlignShapes(pair, T0, params);
    if (r.num_correspondences == 0) continue;
    // More samples inside the (self-tightening) gate first: a wrong fit keeps few of them.
    const bool better = !have || r.num_correspondences > best.num_correspondences ||
                        (r.num_correspondences == best.num_correspondences &&
                         r.rms_error_m < best.rms_error_m);
    if (better) {
      best = r;
      have = true;
    }
  }
  if (!have) best.T_map_scan = fit;
  return best;
}

ShapeMatchResult MatchShapes(const ShapeMatchInput& input,
                             const std::optional<Pose2>& T_model_scan_guess,
                             const ShapeMatcherParams& params) {
  params.Validate();
  if (!input.scan_fine.empty() && input.scan_fine.size() != input.scan.size()) {
    throw std::invalid_argument("MatchShapes: scan_fine must be empty or match scan in size");
  }
  PairEvaluator evaluator(input, params);
  const FitScorer scorer(input, params);
  if (!T_model_scan_guess) return MatchWithoutGuess(input, params, evaluator, scorer);
  CorrespondenceSolution solution =
      SolvePass(input, params, evaluator, *T_model_scan_guess, params.max_group_size,
                params.max_misfit_m);
  ShapeMatchResult result =
      Finish(input, params, scorer, std::move(solution), *T_model_scan_guess);
  result.used_guess = true;
  return result;
}

}  // namespace shape_slam
