// Private (never installed): LaserScan -> mrpt::obs::CObservation2DRangeScan, shared by the
// rawlog writer and the simplemap writer. Conventions in rawlog_writer.h.
#pragma once

#include <mrpt/obs/CObservation2DRangeScan.h>

#include <cstddef>

#include "shape_slam/types.h"

namespace shape_slam::io::internal {

/// The scan as an MRPT observation (sensorLabel "LASER"). Throws LogError naming scan `index`
/// when its beams are not evenly spaced.
mrpt::obs::CObservation2DRangeScan ToMrptScan(const LaserScan& scan, std::size_t index);

}  // namespace shape_slam::io::internal
