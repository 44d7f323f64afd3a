// Uses the MRPT plugin as a library: a polyline map created from an ini text, filled with MRPT's
// example scan, serialized and read back.
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/maps/CMultiMetricMap.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/stock_observations.h>
#include <mrpt/serialization/CArchive.h>

#include <iostream>
#include <string>

#include "shape_slam_mrpt/plugin.h"
#include "shape_slam_mrpt/polyline_map.h"

int main() {
  shape_slam::RegisterMrptClasses();
  const mrpt::config::CConfigFileMemory ini(
      std::string("[map]\npolylineMap_count=1\n[map_polylineMap_00_insertOpts]\nmax_gap_m=0.2\n"));
  mrpt::maps::TSetOfMetricMapInitializers initializers;
  initializers.loadFromConfigFile(ini, "map");
  mrpt::maps::CMultiMetricMap maps(initializers);
  mrpt::obs::CObservation2DRangeScan scan;
  mrpt::obs::stock_observations::example2DRangeScan(scan);
  maps.insertObservation(scan);
  const auto map = maps.mapByClass<shape_slam::CPolylineMap>();
  if (!map || map->isEmpty()) return 1;

  mrpt::io::CMemoryStream buffer;
  auto out = mrpt::serialization::archiveFrom(buffer);
  out << *map;
  buffer.Seek(0);
  auto in = mrpt::serialization::archiveFrom(buffer);
  const auto copy = std::dynamic_pointer_cast<shape_slam::CPolylineMap>(in.ReadObject());
  if (!copy || copy->asString() != map->asString()) return 1;
  std::cout << "consumer_mrpt: " << copy->asString() << "\n";
  return 0;
}
