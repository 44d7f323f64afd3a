#include "shape_slam_io/mrpt_maps.h"

#include <mrpt/io/CStream.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/serialization/CArchive.h>

#include <zlib.h>

#include <cstdint>
#include <string>
#include <utility>

#include "deflate_internal.h"
#include "mrpt_scan_internal.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/ros_map.h"

namespace shape_slam::io {
namespace {

/// An MRPT output stream that gzip-compresses (zlib, level 6) what is written into a string as
/// it comes: a grid map of tens of MB is never held uncompressed.
class GzipStringStream : public mrpt::io::CStream {
 public:
  GzipStringStream() {
    if (deflateInit2(&z_, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
      throw OutputError("cannot start gzip compression");
    }
  }
  ~GzipStringStream() override { deflateEnd(&z_); }
  GzipStringStream(const GzipStringStream&) = delete;
  GzipStringStream& operator=(const GzipStringStream&) = delete;

  size_t Read(void*, size_t) override { throw OutputError("gzip stream: not readable"); }
  size_t Write(const void* buffer, size_t count) override {
    Deflate(std::string_view(static_cast<const char*>(buffer), count), Z_NO_FLUSH);
    written_ += count;
    return count;
  }
  uint64_t Seek(int64_t, TSeekOrigin) override { throw OutputError("gzip stream: not seekable"); }
  uint64_t getTotalBytesCount() const override { return written_; }
  uint64_t getPosition() const override { return written_; }

  /// Ends the compressed stream and returns it.
  std::string Finish() {
    Deflate({}, Z_FINISH);
    return std::move(out_);
  }

 private:
  void Deflate(std::string_view in, int flush) {
    internal::DeflateInto(z_, in, flush, "gzip compression failed",
                          [&](std::string_view block) { out_.append(block); });
  }

  z_stream z_{};
  std::string out_;
  uint64_t written_ = 0;
};

/// What CFileGZOutputStream would write for the object: its serialization, gzip-compressed
/// (compressed as it is serialized).
std::string GzipSerialized(const mrpt::serialization::CSerializable& object, const char* what) {
  try {
    GzipStringStream stream;
    auto archive = mrpt::serialization::archiveFrom(stream);
    archive << object;
    return stream.Finish();
  } catch (const OutputError& e) {
    throw OutputError(std::string("cannot compress the ") + what + ": " + e.what());
  }
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

/// MRPT's map of the grid's size, resolution and origin, every cell unknown.
mrpt::maps::COccupancyGridMap2D EmptyMrptGrid(const OccupancyGrid& frame) {
  const double res = frame.resolution_m;
  mrpt::maps::COccupancyGridMap2D map;
  map.setSize(static_cast<float>(frame.origin_m.x()),
              static_cast<float>(frame.origin_m.x() + frame.width * res),
              static_cast<float>(frame.origin_m.y()),
              static_cast<float>(frame.origin_m.y() + frame.height * res), static_cast<float>(res));
  if (map.getSizeX() != static_cast<unsigned>(frame.width) ||
      map.getSizeY() != static_cast<unsigned>(frame.height)) {
    throw OutputError("the MRPT grid map has " + std::to_string(map.getSizeX()) + " x " +
                      std::to_string(map.getSizeY()) + " cells instead of " +
                      std::to_string(frame.width) + " x " + std::to_string(frame.height));
  }
  return map;
}

}  // namespace

std::string FormatMrptGridmap(OccupancyGrid grid) {
  mrpt::maps::COccupancyGridMap2D map = EmptyMrptGrid(grid);
  for (int iy = 0; iy < grid.height; ++iy) {
    for (int ix = 0; ix < grid.width; ++ix) map.setCell(ix, iy, FreeProbability(grid.At(ix, iy)));
  }
  grid = OccupancyGrid();
  return GzipSerialized(map, "grid map");
}

std::string FormatMrptGridmap(const OccupancyGrid& frame, const std::string& pgm_path) {
  mrpt::maps::COccupancyGridMap2D map = EmptyMrptGrid(frame);
  ReadPgmRows(pgm_path, frame, [&](int iy, const std::vector<CellState>& cells) {
    for (int ix = 0; ix < frame.width; ++ix) map.setCell(ix, iy, FreeProbability(cells[ix]));
  });
  return GzipSerialized(map, "grid map");
}

mrpt::maps::CSimpleMap MakeMrptSimplemap(const std::vector<ShapeSlam::KeyframeView>& keyframes,
                                         const Pose2& T_world_map) {
  mrpt::maps::CSimpleMap simplemap;
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const Pose2 T = T_world_map * keyframes[i].T_map_robot;
    auto frame = mrpt::obs::CSensoryFrame::Create();
    frame->insert(mrpt::obs::CObservation2DRangeScan::Create(
        internal::ToMrptScan(*keyframes[i].scan, i)));
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
