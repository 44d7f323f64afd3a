// shape_slam::CShapeMatcher: ShapeSLAM's scan-to-scan registration (scan_matcher.h: shape
// matching §4.2/§4.3, ICP §5.1, Ceres refinement with covariance) behind MRPT's map alignment
// interface, a drop-in alternative to mrpt::slam::CICP for code that aligns two maps.
//
// AlignPDF(m1, m2, initial) estimates the pose of m2 relative to m1 (MRPT's convention) as a
// CPosePDFGaussian whose covariance is the refinement's (x, y, phi; m^2, m rad, rad^2).
//
// Input: the core matches laser scans, MRPT passes maps. Each map becomes a scan:
//  * a points map (any CPointsMap, e.g. a CSimplePointsMap loaded from one scan) is read as seen
//    from a viewpoint: its points ordered by bearing, the nearest per bearing bin of
//    Options::bearing_bin_rad kept (conversions.h, PointsAsScan); the pipeline's extraction then
//    splits it into polylines by the 0.20 m gap rule (§3.1) and simplifies it;
//  * a CPolylineMap / CPolylinePointsMap contributes its polylines' samples the same way.
// Viewpoints: m2 is seen from its own origin (where its scan was taken). m1 is seen from its
// origin too, unless Options::view_m1_from_guess, where it is seen from the initial estimate:
// use that when m1 is a map built from many scans rather than one scan.
// With Options::use_initial_guess = false the initial estimate is ignored (§4.3: global shape
// matching, e.g. relocalisation).
// Result: a match the refinement did not confirm (ReturnInfo::converged false) comes with the
// covariance kUnconstrainedVariance * I: it carries no information.
#pragma once

#include <mrpt/slam/CMetricMapsAlignmentAlgorithm.h>

#include <string>

#include "shape_slam/pipeline.h"
#include "shape_slam/types.h"

namespace mrpt::config {
class CConfigFileBase;
}  // namespace mrpt::config

namespace shape_slam {

/// Options of CShapeMatcher (see the file comment).
struct CShapeMatcherOptions {
  /// The core's parameters (extraction, DCE, shape matching, refinement, ...).
  ShapeSlamParams params;
  /// Pass AlignPDF's initial estimate to the matcher as a guess (§4.2); false: §4.3.
  bool use_initial_guess = true;
  /// See the file comment.
  bool view_m1_from_guess = false;
  /// Width of the bearing bins that turn point clouds into scans, radians.
  double bearing_bin_rad = 0.25 * M_PI / 180.0;
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

class CShapeMatcher : public mrpt::slam::CMetricMapsAlignmentAlgorithm {
 public:
  using Options = CShapeMatcherOptions;

  /// Everything the matcher reports beside the pose.
  struct ReturnInfo : public mrpt::slam::TMetricMapAlignmentResult {
    bool converged = false;    ///< ScanMatchResult::converged
    double goodness = 0.0;     ///< inlier ratio of m2's samples against m1, [0, 1]
    int matched_pairs = 0;     ///< polyline groups of the eq. (4) correspondence
    int iterations = 0;        ///< refinement rounds
    double rms_error_m = 0.0;  ///< RMS point-to-segment distance at the end
    int scan_points_m1 = 0;    ///< beams of the scan made of m1
    int scan_points_m2 = 0;    ///< beams of the scan made of m2
  };

  /// Throws std::invalid_argument when an option is invalid.
  explicit CShapeMatcher(const Options& options = {});

  const Options& GetOptions() const { return options_; }
  /// Throws std::invalid_argument when an option is invalid.
  void SetOptions(const Options& options);
  /// Reads `use_initial_guess`, `view_m1_from_guess`, `bearing_bin_deg` and, optionally,
  /// `params_file` (a ShapeSLAM parameter ini as `shape-slam` reads, config/default.ini) from
  /// `section`. Unknown keys in the section throw std::invalid_argument naming them.
  void LoadOptions(const mrpt::config::CConfigFileBase& source, const std::string& section);

  /// outInfo may be a ReturnInfo (filled completely) or any TMetricMapAlignmentResult (only
  /// executionTime). Throws std::invalid_argument for maps that are neither points maps nor
  /// polyline maps.
  mrpt::poses::CPosePDF::Ptr AlignPDF(
      const mrpt::maps::CMetricMap* m1, const mrpt::maps::CMetricMap* m2,
      const mrpt::poses::CPosePDFGaussian& initialEstimationPDF,
      mrpt::optional_ref<mrpt::slam::TMetricMapAlignmentResult> outInfo = std::nullopt) override;

  /// AlignPDF on the maps' planar projections from (x, y, yaw) of the initial estimate, returned
  /// as a 3D Gaussian (z, pitch and roll zero, with zero variance).
  mrpt::poses::CPose3DPDF::Ptr Align3DPDF(
      const mrpt::maps::CMetricMap* m1, const mrpt::maps::CMetricMap* m2,
      const mrpt::poses::CPose3DPDFGaussian& initialEstimationPDF,
      mrpt::optional_ref<mrpt::slam::TMetricMapAlignmentResult> outInfo = std::nullopt) override;

 private:
  Options options_;
};

}  // namespace shape_slam
