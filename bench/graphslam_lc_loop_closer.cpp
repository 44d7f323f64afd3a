// The loop closer of bench/graphslam_lc, constructed in a translation unit of its own.
//
// MRPT 2.5.8's CLoopCloserERD segfaults in its constructor when its header is compiled in the
// same translation unit as CGraphSlamEngine.h, CLevMarqGSO.h and CFixedIntervalsNRD.h (as in
// the stock graphslam-engine, which crashes the same way); included alone, after the
// declarations its header lacks, it constructs and runs.
#include <iostream>
using std::endl;  // the header uses `endl` unqualified
#include <mrpt/config/CConfigFile.h>
#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/opengl/CDisk.h>
#include <mrpt/opengl/CPlanarLaserScan.h>
// The order matters: the declarations above first.
#include <mrpt/graphslam/ERD/CLoopCloserERD.h>

#include "graphslam_lc_loop_closer.h"

namespace shape_slam::bench {

std::unique_ptr<mrpt::graphslam::deciders::CEdgeRegistrationDecider<
    mrpt::graphs::CNetworkOfPoses2DInf>>
MakeLoopCloser() {
  return std::make_unique<
      mrpt::graphslam::deciders::CLoopCloserERD<mrpt::graphs::CNetworkOfPoses2DInf>>();
}

}  // namespace shape_slam::bench
