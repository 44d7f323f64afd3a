// Helper of the application tests (mrpt_apps_test.sh): checks the files the stock MRPT
// applications wrote with the plugin, and writes a rawlog holding a plugin object.
//
//   plugin_check map FILE.polylines MIN_POLYLINES   the map file loads and is big enough
//   plugin_check rawlog IN.simplemap OUT.rawlog     a rawlog whose only entry is the
//                                                   shape_slam::CPolylineMap built from IN
//   plugin_check read-rawlog IN.rawlog              reads it back, prints the map's asString()
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/serialization/CArchive.h>

#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>

#include "shape_slam_io/map_file.h"
#include "shape_slam_mrpt/plugin.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace {

int CheckMap(const std::string& path, long min_polylines) {
  const shape_slam::PolylineMap map = shape_slam::io::LoadMapFile(path);
  std::cout << path << ": " << map.NumPolylines() << " polylines, " << map.NumVertices()
            << " vertices\n";
  if (static_cast<long>(map.NumPolylines()) < min_polylines) {
    std::cerr << "expected at least " << min_polylines << " polylines\n";
    return 1;
  }
  return 0;
}

int WriteRawlog(const std::string& simplemap_path, const std::string& rawlog_path) {
  mrpt::maps::CSimpleMap simplemap;
  if (!simplemap.loadFromFile(simplemap_path)) {
    std::cerr << "cannot read " << simplemap_path << "\n";
    return 1;
  }
  shape_slam::CPolylineMap map;
  map.loadFromSimpleMap(simplemap);
  mrpt::io::CFileGZOutputStream out(rawlog_path);
  auto archive = mrpt::serialization::archiveFrom(out);
  archive << map;
  std::cout << map.asString() << "\n";
  return map.isEmpty() ? 1 : 0;
}

int ReadRawlog(const std::string& rawlog_path) {
  mrpt::io::CFileGZInputStream in(rawlog_path);
  auto archive = mrpt::serialization::archiveFrom(in);
  const auto map = std::dynamic_pointer_cast<shape_slam::CPolylineMap>(archive.ReadObject());
  if (!map) {
    std::cerr << rawlog_path << " holds no shape_slam::CPolylineMap\n";
    return 1;
  }
  std::cout << map->asString() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  shape_slam::RegisterMrptClasses();
  const std::string command = argc > 1 ? argv[1] : "";
  try {
    if (command == "map" && argc == 4) return CheckMap(argv[2], std::atol(argv[3]));
    if (command == "rawlog" && argc == 4) return WriteRawlog(argv[2], argv[3]);
    if (command == "read-rawlog" && argc == 3) return ReadRawlog(argv[2]);
  } catch (const std::exception& e) {
    std::cerr << "plugin_check " << command << ": " << e.what() << "\n";
    return 1;
  }
  std::cerr << "usage: plugin_check map FILE.polylines MIN_POLYLINES\n"
               "       plugin_check rawlog IN.simplemap OUT.rawlog\n"
               "       plugin_check read-rawlog IN.rawlog\n";
  return 2;
}
