// Creation of the plugin's maps the way MRPT applications create them: from an ini text through
// TSetOfMetricMapInitializers and CMultiMetricMap; registration; strict option parsing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mrpt/config/CConfigFile.h>
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/maps/CMultiMetricMap.h>
#include <mrpt/maps/TMetricMapInitializer.h>
#include <mrpt/rtti/CObject.h>

#include <fstream>

#include <memory>
#include <stdexcept>
#include <string>

#include "mrpt/mrpt_test_scenes.h"
#include "shape_slam/pipeline.h"
#include "shape_slam_io/map_file.h"
#include "shape_slam_mrpt/plugin.h"
#include "shape_slam_mrpt/polyline_map.h"
#include "shape_slam_mrpt/polyline_points_map.h"

namespace shape_slam {
namespace {

using ::testing::HasSubstr;

const auto* const kPluginEnvironment =
    ::testing::AddGlobalTestEnvironment(new testing::PluginEnvironment);

mrpt::maps::CMultiMetricMap MapsFromIni(const std::string& ini, const std::string& section) {
  const mrpt::config::CConfigFileMemory config(ini);
  mrpt::maps::TSetOfMetricMapInitializers initializers;
  initializers.loadFromConfigFile(config, section);
  return mrpt::maps::CMultiMetricMap(initializers);
}

// The message of the exception `f` throws (MRPT may wrap ours; the text must survive).
template <typename F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}

TEST(PluginRegistration, ClassesAreKnownByNameToRttiAndMapRegistry) {
  RegisterMrptClasses();  // idempotent
  for (const char* name : {"shape_slam::CPolylineMap", "shape_slam::CPolylinePointsMap"}) {
    const mrpt::rtti::TRuntimeClassId* id = mrpt::rtti::findRegisteredClass(name);
    ASSERT_NE(id, nullptr) << name;
    EXPECT_STREQ(id->className, name);
  }
  for (const char* name : {"shape_slam::CPolylineMap", "polylineMap",
                           "shape_slam::CPolylinePointsMap", "polylinePointsMap"}) {
    std::unique_ptr<mrpt::maps::TMetricMapInitializer> definition(
        mrpt::maps::TMetricMapInitializer::factory(name));
    EXPECT_NE(definition, nullptr) << name;
  }
}

TEST(MapCreation, ShortNameWithOptionsInTheThreeSections) {
  const mrpt::maps::CMultiMetricMap maps = MapsFromIni(R"ini(
[map]
polylineMap_count = 1
[map_polylineMap_00_creationOpts]
sample_spacing_m = 0.08
enableObservationLikelihood = false
[map_polylineMap_00_insertOpts]
max_gap_m = 0.3      // comment
min_points = 3
dce_threshold_m = 0.04
visibility_fov_margin_rad = 0.2
[map_polylineMap_00_likelihoodOpts]
sigma_m = 0.1
decimation = 4
)ini",
                                                       "map");
  ASSERT_EQ(maps.maps.size(), 1u);
  const auto map = maps.mapByClass<CPolylineMap>();
  ASSERT_NE(map, nullptr);
  const PolylineMapOptions& o = map->Options();
  EXPECT_DOUBLE_EQ(o.creation.sample_spacing_m, 0.08);
  EXPECT_DOUBLE_EQ(o.insertion.shapes.extraction.max_gap_m, 0.3);
  EXPECT_EQ(o.insertion.shapes.extraction.min_points, 3);
  EXPECT_DOUBLE_EQ(o.insertion.map_update.dce_threshold_m, 0.04);
  EXPECT_DOUBLE_EQ(o.insertion.visibility_fov_margin_rad, 0.2);
  EXPECT_DOUBLE_EQ(o.likelihood.sigma_m, 0.1);
  EXPECT_EQ(o.likelihood.decimation, 4);
  EXPECT_FALSE(map->genericMapParams.enableObservationLikelihood);
  // Keys not given keep the defaults.
  EXPECT_DOUBLE_EQ(o.insertion.map_update.max_deviation_m, MapUpdateParams{}.max_deviation_m);
}

TEST(MapCreation, FullClassNameAndThePointsMapVariant) {
  const mrpt::maps::CMultiMetricMap maps = MapsFromIni(R"ini(
[MappingApplication]
shape_slam::CPolylineMap_count = 1
polylinePointsMap_count = 1
[MappingApplication_polylinePointsMap_00_creationOpts]
sample_spacing_m = 0.1
)ini",
                                                       "MappingApplication");
  ASSERT_EQ(maps.maps.size(), 2u);
  EXPECT_NE(maps.mapByClass<CPolylineMap>(), nullptr);
  const auto points = maps.mapByClass<CPolylinePointsMap>();
  ASSERT_NE(points, nullptr);
  EXPECT_DOUBLE_EQ(points->Options().creation.sample_spacing_m, 0.1);
  // It is the points map icp-slam matches against.
  EXPECT_EQ(maps.countMapsByClass<mrpt::maps::CPointsMap>(), 1u);
}

TEST(MapCreation, DefaultsAreThePipelines) {
  const PolylineMapOptions options;
  const ShapeSlamParams pipeline;
  EXPECT_DOUBLE_EQ(options.creation.index_cell_size_m, pipeline.index_cell_size_m);
  EXPECT_DOUBLE_EQ(options.insertion.shapes.alignment_dce_threshold_m, pipeline.shapes.alignment_dce_threshold_m);
  EXPECT_DOUBLE_EQ(options.insertion.shapes.alignment_max_deviation_m, pipeline.shapes.alignment_max_deviation_m);
  EXPECT_DOUBLE_EQ(options.insertion.visibility_fov_margin_rad, pipeline.visibility_fov_margin_rad);
  EXPECT_DOUBLE_EQ(options.insertion.shapes.extraction.max_gap_m, pipeline.shapes.extraction.max_gap_m);
  EXPECT_DOUBLE_EQ(options.insertion.map_update.dce_threshold_m,
                   pipeline.map_update.dce_threshold_m);
  EXPECT_DOUBLE_EQ(options.insertion.visibility.max_range_m, pipeline.visibility.max_range_m);
}

TEST(MapCreation, UnknownKeyIsAnErrorNamingSectionAndKey) {
  const std::string message = ErrorOf([] {
    MapsFromIni("[map]\npolylineMap_count=1\n[map_polylineMap_00_insertOpts]\nmax_gap=0.3\n",
                "map");
  });
  EXPECT_THAT(message, HasSubstr("ini section 'map_polylineMap_00_insertOpts', key 'max_gap'"));
  EXPECT_THAT(message, HasSubstr("unknown key"));
  EXPECT_THAT(message, HasSubstr("max_gap_m"));  // the known keys are listed
}

TEST(MapCreation, BadValuesAreErrorsNamingTheKey) {
  EXPECT_THAT(
      ErrorOf([] {
        MapsFromIni(
            "[m]\npolylineMap_count=1\n[m_polylineMap_00_likelihoodOpts]\n"
            "sigma_m = abc\n",
            "m");
      }),
      HasSubstr("ini section 'm_polylineMap_00_likelihoodOpts', key 'sigma_m': 'abc' is not "
                "a finite number"));
  EXPECT_THAT(ErrorOf([] {
                MapsFromIni(
                    "[m]\npolylineMap_count=1\n[m_polylineMap_00_insertOpts]\n"
                    "min_points = 2.5\n",
                    "m");
              }),
              HasSubstr("min_points must be an integer"));
  EXPECT_THAT(ErrorOf([] {
                MapsFromIni(
                    "[m]\npolylinePointsMap_count=1\n[m_polylinePointsMap_00_creationOpts]\n"
                    "sample_spacing_m = -1\n",
                    "m");
              }),
              HasSubstr("sample_spacing_m must be > 0"));
}

// The ready ini files of config/mrpt create the plugin's maps in the sections the applications
// read (icp-slam and observations2map: MappingApplication, pf-localization: MetricMap,
// RawLogViewer: map).
TEST(MapCreation, TheShippedIniFilesCreateThePluginsMaps) {
  const std::string dir = std::string(SHAPE_SLAM_TEST_DATA_DIR) + "/../../config/mrpt/";
  struct Case {
    const char* file;
    const char* section;
    std::size_t polyline_maps, polyline_points_maps;
  };
  for (const Case& c : {Case{"icp-slam.ini", "MappingApplication", 0, 1},
                        Case{"observations2map.ini", "MappingApplication", 1, 0},
                        Case{"pf-localization.ini", "MetricMap", 1, 0},
                        Case{"rawlogviewer-map.ini", "map", 1, 0}}) {
    SCOPED_TRACE(c.file);
    const mrpt::config::CConfigFile config(dir + c.file);
    mrpt::maps::TSetOfMetricMapInitializers initializers;
    ASSERT_NO_THROW(initializers.loadFromConfigFile(config, c.section));
    const mrpt::maps::CMultiMetricMap maps(initializers);
    EXPECT_EQ(maps.countMapsByClass<CPolylinePointsMap>(), c.polyline_points_maps);
    EXPECT_EQ(maps.countMapsByClass<CPolylineMap>(), c.polyline_maps);
    // icp-slam matches against the first points map: it must be the polyline one.
    if (c.polyline_points_maps > 0) {
      EXPECT_EQ(maps.countMapsByClass<mrpt::maps::CPointsMap>(), 1u);
    }
  }
}

// pf-localization and other apps create their maps from the ini only: map_file gives the
// polylines of a saved map.polylines (e.g. `shape-slam run`'s) to start with.
TEST(MapCreation, MapFileOptionLoadsSavedPolylines) {
  PolylineMap saved;
  MapPolyline wall;
  wall.points = {Point2(0.0, 0.0), Point2(2.0, 0.0), Point2(2.0, 1.5)};
  wall.support = {1.0, 2.0, 1.0};
  saved.Add(wall);
  const std::string path = ::testing::TempDir() + "/map_creation_test.polylines";
  io::SaveMapFile(path, saved);
  for (const char* name : {"polylineMap", "polylinePointsMap"}) {
    const std::string ini = std::string("[m]\n") + name + "_count=1\n[m_" + name +
                            "_00_creationOpts]\nmap_file = " + path + "\n";
    mrpt::maps::CMultiMetricMap maps = MapsFromIni(ini, "m");
    ASSERT_EQ(maps.maps.size(), 1u) << name;
    const auto* polylines = dynamic_cast<const CPolylineMap*>(maps.maps[0].get());
    const auto* points = dynamic_cast<const CPolylinePointsMap*>(maps.maps[0].get());
    const PolylineMap& map = polylines ? polylines->Map() : points->Polylines().Map();
    EXPECT_EQ(io::FormatMapFile(map), io::FormatMapFile(saved)) << name;
  }
  EXPECT_THAT(ErrorOf([] {
                MapsFromIni("[m]\npolylineMap_count=1\n[m_polylineMap_00_creationOpts]\n"
                            "map_file = /nonexistent/map.polylines\n",
                            "m");
              }),
              HasSubstr("/nonexistent/map.polylines"));
}

TEST(MapCreation, InvalidOptionsInCodeThrow) {
  PolylineMapOptions options;
  options.likelihood.decimation = 0;
  EXPECT_THROW(CPolylineMap{options}, std::invalid_argument);
  EXPECT_THROW(CPolylinePointsMap{options}, std::invalid_argument);
  CPolylineMap map;
  EXPECT_THROW(map.SetOptions(options), std::invalid_argument);
  EXPECT_EQ(map.Options().likelihood.decimation, PolylineMapOptions{}.likelihood.decimation);
}

}  // namespace
}  // namespace shape_slam
