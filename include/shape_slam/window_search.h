// Search of a whole pose window for the poses at which a scan's samples best overlap the model
// polylines: hypotheses for matching without a pose guess (§4.3), beside the alignments that the
// most reliable shape pairs induce.
//
// The paper seeds the matching from the single most reliable pair of polylines (eq. 5). On real
// scans that seed is sometimes wrong (look-alike walls, a salient shape that moved out of view)
// and then nothing recovers. This unit asks another question of the same model: where, within
// +-half_window_m and +-half_window_rad of a centre (the last pose, a constant-velocity
// prediction), does the scan fit at all? The model polylines are rasterised into a likelihood
// field (each cell exp(-d^2 / 2 sigma^2), d its distance to the nearest polyline); the score of
// a pose is the mean field value at the scan's samples, less an optional motion prior. The
// search is exhaustive but bounded: branch and bound over translations on max-pooled copies of
// the field (the idea of Olson's correlative matching and of the branch and bound of Hess et al.,
// "Real-time loop closure in 2D LIDAR SLAM", 2016), best first over every rotation, so it
// visits a small part of the window. It returns the few best distinct poses on the grid (cell
// and angular step); the caller finishes them (ICP, refinement) and chooses among them and the
// shape hypotheses with the candidate selection (candidate_selection.h).
#pragma once

#include <array>
#include <cstdint>
#include <queue>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {
namespace internal {
struct ModelSegment;  // internal/model_segments.h
}  // namespace internal

struct WindowSearchParams {
  /// Cell size of the likelihood field, metres. Coarser is faster; the result is refined later.
  double resolution_m = 0.10;
  /// Width of the likelihood around the polylines, metres.
  double hit_sigma_m = 0.10;
  /// Translations searched: +- this around the centre, in x and in y, metres.
  double half_window_m = 1.5;
  /// Rotations searched: +- this around the centre's heading, radians (pi: all).
  double half_window_rad = 1.2;
  /// The angular step moves the farthest sample by about one cell; samples beyond this range do
  /// not make the step finer (metres).
  double max_step_range_m = 15.0;
  /// At most this many distinct hypotheses are returned, best first ...
  int max_hypotheses = 3;
  /// ... each farther than these from every better one (metres, radians) ...
  double distinct_m = 0.3;
  double distinct_rad = 0.1;
  /// ... and scoring at least this fraction of the best one's score.
  double min_relative_score = 0.7;
  /// Motion prior: a pose's score is lowered by prior_weight * ((|t - t_centre| /
  /// prior_sigma_m)^2 + ((theta - theta_centre) / prior_sigma_rad)^2). Between poses that fit
  /// about equally well (along a featureless corridor) the one nearer the centre wins.
  double prior_weight = 0.02;
  double prior_sigma_m = 1.0;     ///< metres
  double prior_sigma_rad = 0.5;   ///< radians
  /// Bound on the work: search nodes scored (each costs one look-up per sample).
  int max_node_evaluations = 30000;
  /// The likelihood field covers at most this many cells per side (the resolution is coarsened
  /// for larger models).
  int max_cells_per_side = 1024;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// A pose of the window and its score: the mean likelihood of the scan's samples there (0: none
/// near the model, 1: every sample on it), less the motion prior.
struct WindowHypothesis {
  Pose2 T_model_scan;
  double score = 0.0;
  double fit = 0.0;  ///< the mean likelihood alone
};

class WindowSearch {
 public:
  /// Rasterises the model polylines (model frame). Throws std::invalid_argument on invalid
  /// params or non-finite vertices.
  WindowSearch(const std::vector<Polyline>& model, const WindowSearchParams& params = {});

  /// The best distinct poses of the window around T_model_scan_centre for the samples (scan
  /// frame), best first; empty when there are no samples or no model.
  std::vector<WindowHypothesis> Search(const std::vector<Point2>& samples_scan,
                                       const Pose2& T_model_scan_centre) const;
  /// The same in another window: +-half_window_m, +-half_window_rad.
  std::vector<WindowHypothesis> Search(const std::vector<Point2>& samples_scan,
                                       const Pose2& T_model_scan_centre, double half_window_m,
                                       double half_window_rad) const;

  /// The best distinct poses over the whole model, every translation and all turns, best
  /// first: one branch and bound over the field built at construction (its top level is the
  /// window's), so the places that explain the scan poorly are cut early wherever they are.
  /// For a global search (localization without a pose); half_window_m and half_window_rad are
  /// not used, the other params are (give it prior_weight 0: there is no centre to be near).
  std::vector<WindowHypothesis> SearchMap(const std::vector<Point2>& samples_scan) const;

  /// Mean likelihood of the samples at a pose (the fit of WindowHypothesis).
  double Fit(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan) const;

  /// Cell size actually used, metres (resolution_m, or coarser for a large model).
  double ResolutionM() const { return resolution_m_; }

 private:
  struct Node;
  struct CellRange {
    int x0, x1, y0, y1;  // translation offsets searched, cells, inclusive
  };
  // One search's samples at every rotation, its penalties and its node bounds.
  class Scorer {
   public:
    Scorer(const WindowSearch& search, const std::vector<Point2>& samples_scan,
           const Pose2& centre, const CellRange& range, double half_window_rad);
    float Bound(int r, int level, int tx, int ty) const;
    std::priority_queue<Node> TopNodes() const;
    // Writes the node's (up to 4) children one level down into out; returns how many.
    int Children(const Node& node, Node* out) const;
    WindowHypothesis Leaf(const Node& node) const;
    mutable int evaluations = 0;

   private:
    const WindowSearch& search_;
    Pose2 centre_;
    CellRange range_;
    int n_ = 0, rotations_ = 0, half_rotations_ = 0;
    double step_rad_ = 0.0, cell_penalty_ = 0.0, to_score_ = 0.0;
    std::vector<int> cells_;
    // Per rotation: the samples' cells as offsets into a level (iy * nx + ix) and their
    // bounding box (x0, y0, x1, y1): a node whose shifted box lies inside the grid is summed
    // without the per-cell bounds checks of LevelValue (same sums).
    std::vector<long> offsets_;
    std::vector<std::array<int, 4>> boxes_;
    std::vector<double> rotation_penalty_;
  };
  std::vector<std::uint8_t> LikelihoodField(const std::vector<internal::ModelSegment>& segments,
                                            double reach_m) const;
  void BuildPyramid(std::vector<std::uint8_t> field);
  int LevelValue(int level, int ix, int iy) const;
  std::vector<int> RotatedCells(const std::vector<Point2>& samples_scan, const Pose2& centre,
                                int rotations, int half_rotations, double step_rad) const;

  WindowSearchParams params_;
  double resolution_m_ = 0.1;
  Point2 origin_ = Point2::Zero();  // model-frame position of cell (0, 0)'s lower-left corner
  int nx_ = 0, ny_ = 0;             // cells per side, padding included
  int levels_ = 1;
  std::vector<std::vector<std::uint8_t>> pyramid_;  // level k: max over 2^k x 2^k cells
};

}  // namespace shape_slam
