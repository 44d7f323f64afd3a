// The finished map in MRPT's own file formats (built only with MRPT), for MRPT's apps:
//  - a gridmap (`map.gridmap`): a serialized mrpt::maps::COccupancyGridMap2D, gzip-compressed,
//    the format of MRPT's `.gridmap(.gz)` files (pf-localization's map_file, the navigation
//    and grid-matching apps); read it with CFileGZInputStream + archive >> grid.
//  - a simplemap (`map.simplemap`): a serialized mrpt::maps::CSimpleMap, gzip-compressed, as
//    CSimpleMap::saveToFile writes it (observations2map, RawLogViewer): per keyframe a
//    CSensoryFrame holding its CObservation2DRangeScan and the corrected pose as a
//    CPose3DPDFGaussian (mean only, zero covariance).
#pragma once

#include <string>
#include <vector>

#include "shape_slam/pipeline.h"
#include "shape_slam_io/occupancy_grid.h"

namespace mrpt::maps {
class CSimpleMap;
}  // namespace mrpt::maps

namespace shape_slam::io {

/// The gridmap file content: the same cells, size, resolution and origin as `grid`. MRPT's cell
/// value is the probability of being free: 0 (occupied), 1 (free), 0.5 (unknown). Throws
/// OutputError. `grid` is taken by value and released once copied into MRPT's map, before the
/// serialization: a caller done with it moves it in (a large map's grid is tens of MB).
std::string FormatMrptGridmap(OccupancyGrid grid);

/// The same content, the cells read back from `pgm_path`, the image that WritePgm (ros_map.h)
/// wrote for a grid of `frame`'s size, resolution and origin (its cells are not used): only
/// MRPT's map is in memory, not the grid as well. Throws OutputError, MapFileError for an
/// image that is not that grid's.
std::string FormatMrptGridmap(const OccupancyGrid& frame, const std::string& pgm_path);

/// The simplemap file content of the keyframes (ShapeSlam::Keyframes()). Throws LogError for a
/// scan an MRPT 2D range scan cannot hold (rawlog_writer.h), OutputError when compressing fails.
std::string FormatMrptSimplemap(const std::vector<ShapeSlam::KeyframeView>& keyframes);

/// The simplemap itself (what FormatMrptSimplemap serializes), every pose first composed with
/// `T_world_map`. Throws LogError as FormatMrptSimplemap.
mrpt::maps::CSimpleMap MakeMrptSimplemap(const std::vector<ShapeSlam::KeyframeView>& keyframes,
                                         const Pose2& T_world_map = Pose2());

}  // namespace shape_slam::io
