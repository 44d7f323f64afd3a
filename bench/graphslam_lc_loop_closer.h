// MRPT's CLoopCloserERD for 2D graphs, made in a translation unit of its own (see the .cpp).
#pragma once

#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/graphslam/interfaces/CEdgeRegistrationDecider.h>

#include <memory>

namespace shape_slam::bench {

std::unique_ptr<mrpt::graphslam::deciders::CEdgeRegistrationDecider<
    mrpt::graphs::CNetworkOfPoses2DInf>>
MakeLoopCloser();

}  // namespace shape_slam::bench
