// CPolylineMap: insertion, likelihood, matching, serialization, rendering, files, bad input.
#include "shape_slam_mrpt/polyline_map.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/serialization/CArchive.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "mrpt/mrpt_test_scenes.h"
#include "shape_slam/scan_insertion.h"
#include "shape_slam_io/map_file.h"
#include "shape_slam_mrpt/conversions.h"

namespace shape_slam {
namespace {

using testing::MappingPoses;
using testing::RoomWalls;
using testing::SimulateScan;
using testing::ToCPose3D;

CPolylineMap RoomMap() {
  CPolylineMap map;
  for (const Pose2& pose : MappingPoses()) {
    EXPECT_TRUE(map.insertObservation(SimulateScan(pose), ToCPose3D(pose)));
  }
  return map;
}

// Exact equality of two polyline maps: same polylines in the same order, same bookkeeping.
void ExpectSameMaps(const PolylineMap& a, const PolylineMap& b) {
  ASSERT_EQ(a.NumPolylines(), b.NumPolylines());
  const std::vector<PolylineId> ia = a.Ids(), ib = b.Ids();
  for (std::size_t k = 0; k < ia.size(); ++k) {
    const MapPolyline& pa = a.Get(ia[k]);
    const MapPolyline& pb = b.Get(ib[k]);
    ASSERT_EQ(pa.points.size(), pb.points.size());
    for (std::size_t i = 0; i < pa.points.size(); ++i) {
      EXPECT_EQ(pa.points[i], pb.points[i]);
      EXPECT_EQ(pa.support[i], pb.support[i]);
    }
    EXPECT_EQ(pa.observations, pb.observations);
    EXPECT_EQ(pa.contradictions, pb.contradictions);
  }
}

TEST(CPolylineMap, InsertedScansGiveTheRoomsWalls) {
  const CPolylineMap map = RoomMap();
  ASSERT_FALSE(map.isEmpty());
  const std::vector<testing::Wall> walls = RoomWalls();
  // DCE may cut a corner by max_deviation_m (3 cm), merges move walls a little more.
  for (const Point2& p : map.Samples()) {
    EXPECT_LT(testing::DistanceToWalls(p, walls), 0.04) << p.transpose();
  }
  // Much of every long wall is covered.
  int covered = 0, total = 0;
  for (double x = -4.8; x <= 4.8; x += 0.2, ++total) {
    covered += map.DistanceToPolylines(Point2(x, -3.0), 0.05) < 0.05 ? 1 : 0;
  }
  EXPECT_GT(covered, total * 0.8);
  EXPECT_THAT(map.asString(), ::testing::HasSubstr("polylines"));
}

// Issue 13: the plugin inserts as the core does (scan_insertion.h): the same scans at the same
// poses give exactly the map the core's InsertScan builds from the rawlog reader's conversion.
TEST(CPolylineMap, MapIsTheCoresInsertionOfTheSameScansAtTheSamePoses) {
  const CPolylineMap plugin = RoomMap();
  const PolylineMapOptions options;
  PolylineMap core(options.creation.index_cell_size_m);
  for (const Pose2& pose : MappingPoses()) {
    // The pose as the plugin receives it (through a CPose3D), so that both see the same bits.
    const Pose2 T_map_robot = ToPose2(ToCPose3D(pose));
    const ScanInsertionResult inserted =
        InsertScan(core, ToLaserScan(SimulateScan(pose)), T_map_robot, true, options.insertion);
    EXPECT_GT(inserted.polylines, 0);
  }
  ASSERT_FALSE(core.Empty());
  ExpectSameMaps(plugin.Map(), core);
}

TEST(CPolylineMap, OnlyLaserScansAreInserted) {
  CPolylineMap map;
  mrpt::obs::CObservationOdometry odometry;
  EXPECT_FALSE(map.insertObservation(odometry));
  EXPECT_TRUE(map.isEmpty());
  EXPECT_FALSE(map.canComputeObservationLikelihood(odometry));
  EXPECT_DOUBLE_EQ(map.computeObservationLikelihood(odometry, mrpt::poses::CPose3D()), 0.0);
}

TEST(CPolylineMap, MalformedScanIsAClearErrorNotACrash) {
  CPolylineMap map;
  mrpt::obs::CObservation2DRangeScan scan = SimulateScan(Pose2());
  scan.aperture = 0.0f;
  try {
    map.insertObservation(scan);
    FAIL() << "no exception";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("aperture"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("SIM_LASER"));
  }
  mrpt::obs::CObservation2DRangeScan empty;
  EXPECT_THROW(map.insertObservation(empty), std::exception);
  EXPECT_TRUE(map.isEmpty());
}

TEST(CPolylineMap, NonFinitePosesAreHandled) {
  CPolylineMap map = RoomMap();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const mrpt::poses::CPose3D bad(nan, 0.0, 0.0, 0.0, 0.0, 0.0);
  const mrpt::obs::CObservation2DRangeScan scan = SimulateScan(Pose2());
  EXPECT_THROW(map.insertObservation(scan, bad), std::invalid_argument);
  // A NaN particle explains nothing: every reading counts as a miss.
  const double at_nan = map.computeObservationLikelihood(scan, bad);
  EXPECT_TRUE(std::isfinite(at_nan));
  EXPECT_LT(at_nan, map.computeObservationLikelihood(scan, ToCPose3D(Pose2())));
  mrpt::tfest::TMatchingPairList pairs;
  mrpt::maps::TMatchingExtraResults extra;
  const mrpt::maps::CSimplePointsMap points = testing::ScanPoints(scan);
  map.determineMatching2D(&points, mrpt::poses::CPose2D(nan, 0, 0), pairs, {}, extra);
  EXPECT_TRUE(pairs.empty());
}

TEST(CPolylineMap, LikelihoodIsHighestAtTheTruePose) {
  const CPolylineMap map = RoomMap();
  const Pose2 truth(0.7, -0.8, 0.4);
  const mrpt::obs::CObservation2DRangeScan scan = SimulateScan(truth);
  const double at_truth = map.computeObservationLikelihood(scan, ToCPose3D(truth));
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> offset(-0.3, 0.3), turn(-0.15, 0.15);
  for (int trial = 0; trial < 30; ++trial) {
    const Pose2 perturbed(truth.x + offset(prng), truth.y + offset(prng), truth.theta + turn(prng));
    EXPECT_GT(at_truth, map.computeObservationLikelihood(scan, ToCPose3D(perturbed)))
        << "trial " << trial;
  }
  // Small, single-axis perturbations too.
  for (const Pose2& d : {Pose2(0.05, 0, 0), Pose2(0, -0.05, 0), Pose2(0, 0, 0.02)}) {
    EXPECT_GT(at_truth, map.computeObservationLikelihood(scan, ToCPose3D(truth * d)));
  }
}

TEST(CPolylineMap, MatchingAgainstAPointsMapPairsPointsWithTheWalls) {
  const CPolylineMap map = RoomMap();
  const Pose2 truth(-1.5, 1.0, -0.7);
  const mrpt::maps::CSimplePointsMap points = testing::ScanPoints(SimulateScan(truth));
  mrpt::maps::TMatchingParams params;
  params.maxDistForCorrespondence = 0.3f;
  mrpt::tfest::TMatchingPairList pairs;
  mrpt::maps::TMatchingExtraResults extra;
  map.determineMatching2D(&points, ToCPose2D(truth), pairs, params, extra);
  EXPECT_GT(extra.correspondencesRatio, 0.9f);
  ASSERT_FALSE(pairs.empty());
  const std::vector<Point2>& samples = map.Samples();
  std::size_t on_wall = 0;
  for (const auto& pair : pairs) {
    // Points of walls the map has not seen pair with what lies within the gate.
    on_wall += pair.errorSquareAfterTransformation < 0.03f * 0.03f ? 1 : 0;
    ASSERT_LT(pair.globalIdx, samples.size());
    // globalIdx is the sample nearest to the paired point.
    EXPECT_LT((samples[pair.globalIdx] - Point2(pair.global.x, pair.global.y)).norm(),
              map.Options().creation.sample_spacing_m);
    EXPECT_FLOAT_EQ(pair.local.x, points.getPointsBufferRef_x()[pair.localIdx]);
  }
  EXPECT_GT(on_wall, pairs.size() * 9 / 10);
  // Far off, nothing pairs.
  map.determineMatching2D(&points, ToCPose2D(truth * Pose2(0, 0, 1.5)), pairs, params, extra);
  EXPECT_LT(extra.correspondencesRatio, 0.5f);

  mrpt::maps::TMatchingRatioParams ratio_params;
  ratio_params.maxDistForCorr = 0.05f;
  EXPECT_GT(map.compute3DMatchingRatio(&points, ToCPose3D(truth), ratio_params), 0.9f);
  EXPECT_NEAR(map.squareDistanceToClosestCorrespondence(0.0f, -2.5f), 0.25f, 0.01f);
}

TEST(CPolylineMap, MatchingAgainstAnUnsupportedMapIsAClearError) {
  const CPolylineMap map = RoomMap();
  mrpt::tfest::TMatchingPairList pairs;
  mrpt::maps::TMatchingExtraResults extra;
  EXPECT_THROW(map.determineMatching2D(nullptr, {}, pairs, {}, extra), std::invalid_argument);
}

TEST(CPolylineMap, SerializationRoundTripIsExact) {
  PolylineMapOptions options;
  options.insertion.shapes.extraction.max_gap_m = 0.25;
  options.likelihood.sigma_m = 0.12;
  CPolylineMap map(options);
  for (const Pose2& pose : MappingPoses())
    map.insertObservation(SimulateScan(pose), ToCPose3D(pose));
  map.genericMapParams.enableObservationLikelihood = false;

  mrpt::io::CMemoryStream buffer;
  auto out = mrpt::serialization::archiveFrom(buffer);
  out << map;
  buffer.Seek(0);
  auto in = mrpt::serialization::archiveFrom(buffer);
  const mrpt::serialization::CSerializable::Ptr object = in.ReadObject();
  const auto copy = std::dynamic_pointer_cast<CPolylineMap>(object);
  ASSERT_NE(copy, nullptr);
  ExpectSameMaps(map.Map(), copy->Map());
  EXPECT_EQ(map.Options(), copy->Options());
  EXPECT_FALSE(copy->genericMapParams.enableObservationLikelihood);
  EXPECT_EQ(map.Samples(), copy->Samples());
}

TEST(CPolylineMap, TruncatedArchiveIsAnErrorNotACrash) {
  const CPolylineMap map = RoomMap();
  mrpt::io::CMemoryStream buffer;
  auto out = mrpt::serialization::archiveFrom(buffer);
  out << map;
  const std::uint64_t size = buffer.getTotalBytesCount();
  for (const std::uint64_t cut : {size / 3, size / 2, size - 3}) {
    mrpt::io::CMemoryStream truncated;
    truncated.Write(buffer.getRawBufferData(), cut);
    truncated.Seek(0);
    auto in = mrpt::serialization::archiveFrom(truncated);
    EXPECT_THROW(in.ReadObject(), std::exception) << "cut at " << cut << " of " << size;
  }
}

TEST(CPolylineMap, VisualizationHoldsEverySegment) {
  const CPolylineMap map = RoomMap();
  mrpt::opengl::CSetOfObjects scene;
  map.getVisualizationInto(scene);
  std::size_t segments = 0;
  for (const PolylineId id : map.Map().Ids()) segments += map.Map().Get(id).points.size() - 1;
  const auto lines = scene.getByClass<mrpt::opengl::CSetOfLines>();
  ASSERT_NE(lines, nullptr);
  EXPECT_EQ(lines->getLineCount(), segments);
}

TEST(CPolylineMap, SavesALoadableMapFileAndAnSvg) {
  const CPolylineMap map = RoomMap();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("shape_slam_mrpt_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string prefix = (dir / "room").string();
  map.saveMetricMapRepresentationToFile(prefix);
  const PolylineMap loaded = io::LoadMapFile(prefix + ".polylines");
  ExpectSameMaps(map.Map(), loaded);
  std::ifstream svg(prefix + ".svg");
  std::stringstream text;
  text << svg.rdbuf();
  EXPECT_THAT(text.str(), ::testing::HasSubstr("<svg"));
  std::filesystem::remove_all(dir);
  // An unwritable place is an exception, not a crash.
  EXPECT_THROW(map.saveMetricMapRepresentationToFile("/nonexistent-dir/x/map"), std::exception);
}

TEST(CPolylineMap, ClearEmptiesAndSetMapReplaces) {
  CPolylineMap map = RoomMap();
  const PolylineMap polylines = map.Map();
  map.clear();
  EXPECT_TRUE(map.isEmpty());
  EXPECT_TRUE(map.Samples().empty());
  map.SetMap(polylines);
  ExpectSameMaps(polylines, map.Map());
  EXPECT_FALSE(map.Samples().empty());
}

}  // namespace
}  // namespace shape_slam
