// CPolylinePointsMap: the points are the polylines' samples; MRPT's ICP uses it as reference;
// serialization; CMultiMetricMap holding the plugin's maps copies them.
#include "shape_slam_mrpt/polyline_points_map.h"

#include <gtest/gtest.h>
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/maps/CMultiMetricMap.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/serialization/CArchive.h>
#include <mrpt/slam/CICP.h>

#include <random>

#include "core/pose_matchers.h"
#include "mrpt/mrpt_test_scenes.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

using testing::MappingPoses;
using testing::SimulateScan;
using testing::ToCPose3D;

void Fill(mrpt::maps::CMetricMap& map) {
  for (const Pose2& pose : MappingPoses())
    map.insertObservation(SimulateScan(pose), ToCPose3D(pose));
}

std::vector<Point2> Points(const mrpt::maps::CPointsMap& points) { return PointsOf(points); }

TEST(CPolylinePointsMap, ItsPointsAreThePolylinesSamples) {
  CPolylinePointsMap map;
  Fill(map);
  ASSERT_FALSE(map.Polylines().isEmpty());
  const std::vector<Point2>& samples = map.Polylines().Samples();
  const std::vector<Point2> points = Points(map);
  ASSERT_EQ(points.size(), samples.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR((points[i] - samples[i]).norm(), 0.0, 1e-5);
  }
  // Every point is on a wall of the room, and they are spaced as configured.
  for (const Point2& p : points) EXPECT_LT(testing::DistanceToWalls(p, testing::RoomWalls()), 0.04);
  map.clear();
  EXPECT_EQ(map.size(), 0u);
  EXPECT_TRUE(map.Polylines().isEmpty());
}

// The ICP of icp-slam (CICP, icpClassic), with `map` as the reference, finds the pose of a
// scan from a perturbed start, `trials` seeded times.
void ExpectIcpRecoversPoses(const CPolylinePointsMap& map, unsigned seed, int trials,
                            double tolerance_m) {
  mrpt::slam::CICP icp;
  icp.options.ICP_algorithm = mrpt::slam::icpClassic;
  icp.options.thresholdDist = 0.5f;
  icp.options.thresholdAng = 0.05f;
  icp.options.ALFA = 0.8f;
  icp.options.smallestThresholdDist = 0.05f;
  icp.options.onlyUniqueRobust = true;
  icp.options.maxIterations = 100;
  std::mt19937 prng(seed);
  std::uniform_real_distribution<double> x(-3.0, 3.0), y(-2.0, 2.0), heading(-M_PI, M_PI);
  std::uniform_real_distribution<double> offset(-0.2, 0.2), turn(-0.08, 0.08);
  for (int trial = 0; trial < trials; ++trial) {
    const Pose2 truth(x(prng), y(prng), heading(prng));
    const mrpt::maps::CSimplePointsMap scan = testing::ScanPoints(SimulateScan(truth));
    const Pose2 start = truth * Pose2(offset(prng), offset(prng), turn(prng));
    mrpt::slam::CICP::TReturnInfo info;
    const mrpt::poses::CPosePDF::Ptr pdf = icp.Align(&map, &scan, ToCPose2D(start), info);
    EXPECT_THAT(ToPose2(pdf->getMeanVal()), IsNearly(truth, tolerance_m, 0.01)) << trial;
    EXPECT_GT(info.goodness, 0.8) << "trial " << trial;
  }
}

TEST(CPolylinePointsMap, MrptIcpAgainstItRecoversThePose) {
  CPolylinePointsMap map;
  Fill(map);
  ExpectIcpRecoversPoses(map, 42, 10, 0.02);
}

// A serialized and read back copy of `map`, with every option and point.
std::shared_ptr<CPolylinePointsMap> RoundTrip(const CPolylinePointsMap& map) {
  mrpt::io::CMemoryStream buffer;
  auto out = mrpt::serialization::archiveFrom(buffer);
  out << map;
  buffer.Seek(0);
  auto in = mrpt::serialization::archiveFrom(buffer);
  return std::dynamic_pointer_cast<CPolylinePointsMap>(in.ReadObject());
}

TEST(CPolylinePointsMap, SerializationRoundTripIsExact) {
  PolylineMapOptions options;
  options.creation.sample_spacing_m = 0.07;
  CPolylinePointsMap map(options);
  Fill(map);
  const auto copy = RoundTrip(map);
  ASSERT_NE(copy, nullptr);
  EXPECT_EQ(copy->Options(), map.Options());
  EXPECT_EQ(copy->Polylines().Samples(), map.Polylines().Samples());
  EXPECT_EQ(Points(*copy), Points(map));
}

PolylineMapOptions KeepingScanPoints() {
  PolylineMapOptions options;
  options.creation.keep_scan_points = true;
  return options;
}

// keep_scan_points: the cloud is the samples, then every inserted scan's points as a
// CSimplePointsMap with the same spacing holds them; the polylines are unchanged.
TEST(CPolylinePointsMap, KeptScanPointsFollowTheSamplesAndLeaveThePolylinesAlone) {
  CPolylinePointsMap plain, keeping(KeepingScanPoints());
  Fill(plain);
  Fill(keeping);
  mrpt::maps::CSimplePointsMap stock;
  stock.insertionOptions.minDistBetweenLaserPoints = 0.05f;
  Fill(stock);
  EXPECT_EQ(keeping.Polylines().Samples(), plain.Polylines().Samples());
  const std::vector<Point2>& samples = keeping.Polylines().Samples();
  const std::vector<Point2> points = Points(keeping), scan_points = Points(stock);
  ASSERT_EQ(points.size(), samples.size() + scan_points.size());
  for (std::size_t i = 0; i < scan_points.size(); ++i) {
    EXPECT_NEAR((points[samples.size() + i] - scan_points[i]).norm(), 0.0, 1e-6) << i;
  }
  keeping.clear();
  EXPECT_EQ(keeping.size(), 0u);
}

TEST(CPolylinePointsMap, WithKeptScanPointsMrptIcpRecoversThePose) {
  CPolylinePointsMap map(KeepingScanPoints());
  Fill(map);
  ExpectIcpRecoversPoses(map, 7, 5, 0.03);
}

TEST(CPolylinePointsMap, SerializationRoundTripKeepsTheScanPoints) {
  CPolylinePointsMap map(KeepingScanPoints());
  Fill(map);
  const auto copy = RoundTrip(map);
  ASSERT_NE(copy, nullptr);
  EXPECT_TRUE(copy->Options().creation.keep_scan_points);
  EXPECT_GT(copy->size(), copy->Polylines().Samples().size());
  EXPECT_EQ(Points(*copy), Points(map));
}

// A CMultiMetricMap holding both plugin maps (and a stock one) copies them completely, and the
// copies are independent of the original.
TEST(CMultiMetricMapWithPluginMaps, CopiesAreCompleteAndIndependent) {
  const mrpt::config::CConfigFileMemory config(std::string(R"ini(
[map]
polylineMap_count = 1
polylinePointsMap_count = 1
occupancyGrid_count = 1
[map_polylineMap_00_insertOpts]
max_gap_m = 0.25
)ini"));
  mrpt::maps::TSetOfMetricMapInitializers initializers;
  initializers.loadFromConfigFile(config, "map");
  mrpt::maps::CMultiMetricMap original(initializers);
  ASSERT_EQ(original.maps.size(), 3u);
  Fill(original);
  const auto polylines = original.mapByClass<CPolylineMap>();
  const auto points = original.mapByClass<CPolylinePointsMap>();
  ASSERT_FALSE(polylines->isEmpty());

  mrpt::maps::CMultiMetricMap copy(original);
  mrpt::maps::CMultiMetricMap assigned;
  assigned = original;
  for (const mrpt::maps::CMultiMetricMap* m : {&copy, &assigned}) {
    ASSERT_EQ(m->maps.size(), 3u);
    const auto p = m->mapByClass<CPolylineMap>();
    const auto q = m->mapByClass<CPolylinePointsMap>();
    ASSERT_NE(p, nullptr);
    ASSERT_NE(q, nullptr);
    EXPECT_NE(p.get(), polylines.get());  // deep copies
    EXPECT_EQ(p->Samples(), polylines->Samples());
    EXPECT_EQ(p->Options(), polylines->Options());
    EXPECT_DOUBLE_EQ(p->Options().insertion.shapes.extraction.max_gap_m, 0.25);
    EXPECT_EQ(Points(*q), Points(*points));
  }
  original.clear();
  EXPECT_TRUE(polylines->isEmpty());
  EXPECT_FALSE(copy.mapByClass<CPolylineMap>()->isEmpty());
  EXPECT_FALSE(assigned.mapByClass<CPolylinePointsMap>()->isEmpty());
}

}  // namespace
}  // namespace shape_slam
