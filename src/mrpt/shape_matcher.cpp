#include "shape_slam_mrpt/shape_matcher.h"

#include <mrpt/config/CConfigFileBase.h>
#include <mrpt/maps/CPointsMap.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/poses/CPosePDFGaussian.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "shape_slam/alignment_refinement.h"
#include "shape_slam/scan_matcher.h"
#include "shape_slam_io/params_ini.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"
#include "shape_slam_mrpt/polyline_points_map.h"

#include "option_fields.h"

namespace shape_slam {
namespace {

constexpr const char* kAlignPdf = "shape_slam::CShapeMatcher::AlignPDF";

// The points a map offers the matcher, in its own frame.
std::vector<Point2> MapPoints(const mrpt::maps::CMetricMap* map, const char* name) {
  if (map == nullptr)
    throw std::invalid_argument(std::string(kAlignPdf) + ": " + name + " is null");
  if (const auto* p = dynamic_cast<const CPolylinePointsMap*>(map)) return p->Polylines().Samples();
  if (const auto* p = dynamic_cast<const CPolylineMap*>(map)) return p->Samples();
  if (const auto* p = dynamic_cast<const mrpt::maps::CPointsMap*>(map)) return PointsOf(*p);
  throw std::invalid_argument(std::string(kAlignPdf) + ": " + name + " is a " +
                              map->GetRuntimeClass()->className +
                              "; a points map or a shape_slam polyline map is needed");
}

mrpt::math::CMatrixDouble33 ToMrpt(const Eigen::Matrix3d& m) {
  mrpt::math::CMatrixDouble33 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m(r, c);
  }
  return out;
}


double ParseNumber(const std::string& text, const std::string& where) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value)) {
    throw std::invalid_argument(where + ": '" + text + "' is not a finite number");
  }
  return value;
}

}  // namespace

void CShapeMatcherOptions::Validate() const {
  params.Validate();
  if (!(bearing_bin_rad > 0.0) || !std::isfinite(bearing_bin_rad)) {
    throw std::invalid_argument("CShapeMatcherOptions::bearing_bin_rad must be > 0");
  }
}

CShapeMatcher::CShapeMatcher(const Options& options) : options_(options) { options_.Validate(); }

void CShapeMatcher::SetOptions(const Options& options) {
  options.Validate();
  options_ = options;
}

void CShapeMatcher::LoadOptions(const mrpt::config::CConfigFileBase& source,
                                const std::string& section) {
  Options options = options_;
  std::vector<std::string> keys;
  source.getAllKeys(section, keys);
  for (const std::string& key : keys) {
    const std::string where = "ini section '" + section + "', key '" + key + "'";
    const std::string value = source.read_string(section, key, "");
    const std::string k = Lower(key);
    if (k == "use_initial_guess") {
      options.use_initial_guess = ParseBool(value, where);
    } else if (k == "view_m1_from_guess") {
      options.view_m1_from_guess = ParseBool(value, where);
    } else if (k == "bearing_bin_deg") {
      options.bearing_bin_rad = ParseNumber(value, where) * M_PI / 180.0;
    } else if (k == "params_file") {
      try {
        options.params = io::LoadParamsIni(value);
      } catch (const io::ConfigError& e) {
        throw std::invalid_argument(where + ": " + e.what());
      }
    } else {
      throw std::invalid_argument(where +
                                  ": unknown key (known keys: use_initial_guess, "
                                  "view_m1_from_guess, bearing_bin_deg, params_file)");
    }
  }
  try {
    options.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("ini section '" + section + "': " + e.what());
  }
  options_ = options;
}

mrpt::poses::CPosePDF::Ptr CShapeMatcher::AlignPDF(
    const mrpt::maps::CMetricMap* m1, const mrpt::maps::CMetricMap* m2,
    const mrpt::poses::CPosePDFGaussian& initialEstimationPDF,
    mrpt::optional_ref<mrpt::slam::TMetricMapAlignmentResult> outInfo) {
  const auto start = std::chrono::steady_clock::now();
  const Pose2 guess_T_m1_m2 = ToPose2(initialEstimationPDF.mean);
  const Pose2 viewpoint_m1 = options_.view_m1_from_guess ? guess_T_m1_m2 : Pose2();
  const LaserScan scan_1 =
      PointsAsScan(MapPoints(m1, "m1"), viewpoint_m1, options_.bearing_bin_rad);
  const LaserScan scan_2 = PointsAsScan(MapPoints(m2, "m2"), Pose2(), options_.bearing_bin_rad);
  const std::optional<Pose2> guess =
      options_.use_initial_guess ? std::optional<Pose2>(guess_T_m1_m2) : std::nullopt;
  ScanMatchResult result = MatchScans(scan_1, scan_2, guess, ToScanMatchParams(options_.params));
  if (!options_.use_initial_guess && !result.converged) result.T_i_j = guess_T_m1_m2;
  // An estimate no refinement confirmed carries no information.
  const Eigen::Matrix3d covariance =
      result.converged ? result.covariance
                       : Eigen::Matrix3d(kUnconstrainedVariance * Eigen::Matrix3d::Identity());
  auto pdf =
      std::make_shared<mrpt::poses::CPosePDFGaussian>(ToCPose2D(result.T_i_j), ToMrpt(covariance));
  if (outInfo) {
    mrpt::slam::TMetricMapAlignmentResult& info = outInfo->get();
    info.executionTime =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (auto* details = dynamic_cast<ReturnInfo*>(&info)) {
      details->converged = result.converged;
      details->goodness = result.inlier_ratio;
      details->matched_pairs = result.matched_pairs;
      details->iterations = result.iterations;
      details->rms_error_m = result.rms_error_m;
      details->scan_points_m1 = static_cast<int>(scan_1.ranges_m.size());
      details->scan_points_m2 = static_cast<int>(scan_2.ranges_m.size());
    }
  }
  return pdf;
}

mrpt::poses::CPose3DPDF::Ptr CShapeMatcher::Align3DPDF(
    const mrpt::maps::CMetricMap* m1, const mrpt::maps::CMetricMap* m2,
    const mrpt::poses::CPose3DPDFGaussian& initialEstimationPDF,
    mrpt::optional_ref<mrpt::slam::TMetricMapAlignmentResult> outInfo) {
  const mrpt::poses::CPosePDFGaussian initial_2d(initialEstimationPDF);
  const mrpt::poses::CPosePDF::Ptr pdf_2d = AlignPDF(m1, m2, initial_2d, outInfo);
  const auto& gaussian_2d = dynamic_cast<const mrpt::poses::CPosePDFGaussian&>(*pdf_2d);
  return std::make_shared<mrpt::poses::CPose3DPDFGaussian>(gaussian_2d);
}

}  // namespace shape_slam
