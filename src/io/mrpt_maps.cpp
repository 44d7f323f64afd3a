#include "shape_slam_io/mrpt_maps.h"

#include <mrpt/io/CMemoryStream.h>
#include <mrpt/io/zip.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/serialization/CArchive.h>

#include <cstdint>

#include "mrpt_scan_internal.h"
#include "shape_slam_io/atomic_file.h"

namespace shape_slam::io {
namespace {

/// What CFileGZOutputStream would write for the object: its serialization, gzip-compressed.
std::string GzipSerialized(const mrpt::serialization::CSerializable& object, const char* what) {
  mrpt::io::CMemoryStream buffer;
  auto archive = mrpt::serialization::archiveFrom(buffer);
  archive << object;
  const auto* data = static_cast<const std::uint8_t*>(buffer.getRawBufferData());
  const std::vector<std::uint8_t> plain(data, data + buffer.getTotalBytesCount());
  std::vector<std::uint8_t> gz;
  if (!mrpt::io::zip::compress_gz_data_block(plain, gz, 6)) {
    throw OutputError(std::string("cannot compress the ") + what);
  }
  return std::string(gz.begin(), gz.end());
}

/// MRPT's cell value is the probability of the cell being FREE: 1 free, 0 occupied (see
/// COccupancyGridMap2D::isStaticCell, which calls a cell occupied at or below a threshold).
float FreeProbability(CellState state) {
  switch (state) {
    case CellState::kOccupied: return 0.0f;
    case CellState::kFree: return 1.0f;
    case CellState::kUnknown: break;
  }
  return 0.5f;
}

}  // namespace

std::string FormatMrptGridmap(const OccupancyGrid& grid) {
  const double res = grid.resolution_m;
  mrpt::maps::COccupancyGridMap2D map;
  map.setSize(static_cast<float>(grid.origin_m.x()),
              static_cast<float>(grid.origin_m.x() + grid.width * res),
              static_cast<float>(grid.origin_m.y()),
              static_cast<float>(grid.origin_m.y() + grid.height * res), static_cast<float>(res));
  if (map.getSizeX() != static_cast<unsigned>(grid.width) ||
      map.getSizeY() != static_cast<unsigned>(grid.height)) {
    throw OutputError("the MRPT grid map has " + std::to_string(map.getSizeX()) + " x " +
                      std::to_string(map.getSizeY()) + " cells instead of " +
                      std::to_string(grid.width) + " x " + std::to_string(grid.height));
  }
  for (int iy = 0; iy < grid.height; ++iy) {
    for (int ix = 0; ix < grid.width; ++ix) map.setCell(ix, iy, FreeProbability(grid.At(ix, iy)));
  }
  return GzipSerialized(map, "grid map");
}

mrpt::maps::CSimpleMap MakeMrptSimplemap(const std::vector<ShapeSlam::KeyframeView>& keyframes,
                                         const Pose2& T_world_map) {
  mrpt::maps::CSimpleMap simplemap;
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const Pose2 T = T_world_map * keyframes[i].T_map_robot;
    auto frame = mrpt::obs::CSensoryFrame::Create();
    frame->insert(mrpt::obs::CObservation2DRangeScan::Create(
        internal::ToMrptScan(keyframes[i].scan, i)));
    auto pose = mrpt::poses::CPose3DPDFGaussian::Create(
        mrpt::poses::CPose3D(T.x, T.y, 0.0, T.theta, 0.0, 0.0));
    simplemap.insert(pose, frame);
  }
  return simplemap;
}

std::string FormatMrptSimplemap(const std::vector<ShapeSlam::KeyframeView>& keyframes) {
  return GzipSerialized(MakeMrptSimplemap(keyframes), "simple map");
}

}  // namespace shape_slam::io
