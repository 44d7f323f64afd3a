// graphslam_lc: MRPT's graph SLAM with its loop closer, run over the library class.
//
//   graphslam_lc INI PAIRS_RAWLOG OUT_NODES
//
// What `graphslam-engine --2d -i INI -r RAWLOG -n CFixedIntervalsNRD -e CLoopCloserERD
// -o CLevMarqGSO` would do, headless: a CGraphSlamEngine<CNetworkOfPoses2DInf> with these
// deciders, fed every action-observation pair of the rawlog. The stock graphslam-engine of
// MRPT 2.5.8 segfaults while constructing CLoopCloserERD (exit 139 before reading any data, on
// MRPT's own sample log too); constructed in a translation unit of its own
// (graphslam_lc_loop_closer.cpp), the same class runs. The engine's own output
// files (output_dir_fname of the INI) are not written: OUT_NODES is the output.
//
// OUT_NODES (written to OUT_NODES.tmp, then renamed): `node scan timestamp x y phi` per node of
// the final (optimised) graph, where scan is the 0-based index of the pair whose step
// registered the node (the root node: the first pair) and timestamp that pair's scan's.
#include <mrpt/core/Clock.h>
#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/serialization/CArchive.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>

// MRPT 2.5.8's graphslam headers use `endl`, CSphere, CDisk and CConfigFile without declaring
// them.
using std::endl;
#include <mrpt/config/CConfigFile.h>
#include <mrpt/opengl/CDisk.h>
#include <mrpt/opengl/CSphere.h>
// The order matters: the declarations above first.
#include <mrpt/graphslam/CGraphSlamEngine.h>
#include <mrpt/graphslam/GSO/CLevMarqGSO.h>
#include <mrpt/graphslam/NRD/CFixedIntervalsNRD.h>

#include "graphslam_lc_loop_closer.h"

namespace {

using Graph = mrpt::graphs::CNetworkOfPoses2DInf;

struct NodeScan {
  std::size_t scan = 0;
  double timestamp_s = 0.0;
};

double ScanTimestamp(const mrpt::obs::CSensoryFrame::Ptr& frame,
                     const mrpt::obs::CObservation::Ptr& observation) {
  if (frame && !frame->empty()) return mrpt::Clock::toDouble((*frame->begin())->timestamp);
  if (observation) return mrpt::Clock::toDouble(observation->timestamp);
  return 0.0;
}

// Runs the engine over the rawlog; the scan (pair index) at which each node appeared, the
// root node (id 0, the start pose) at the first.
std::map<mrpt::graphs::TNodeID, NodeScan> Run(mrpt::graphslam::CGraphSlamEngine<Graph>& engine,
                                              const std::string& rawlog) {
  mrpt::io::CFileGZInputStream input(rawlog);
  auto archive = mrpt::serialization::archiveFrom(input);
  mrpt::obs::CActionCollection::Ptr actions;
  mrpt::obs::CSensoryFrame::Ptr frame;
  mrpt::obs::CObservation::Ptr observation;
  std::size_t entry = 0, scan = 0;
  std::map<mrpt::graphs::TNodeID, NodeScan> node_scans;
  std::optional<NodeScan> first;
  while (mrpt::obs::CRawlog::getActionObservationPairOrObservation(archive, actions, frame,
                                                                   observation, entry)) {
    if (!engine._execGraphSlamStep(actions, frame, observation, entry)) break;
    const NodeScan here{scan, ScanTimestamp(frame, observation)};
    if (!first) first = here;
    for (const auto& node : engine.getGraph().nodes) {
      if (!node_scans.count(node.first)) node_scans[node.first] = node.first == 0 ? *first : here;
    }
    ++scan;
  }
  return node_scans;
}

void WriteNodes(const Graph& graph, const std::map<mrpt::graphs::TNodeID, NodeScan>& node_scans,
                const std::string& path) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    out << "# node scan timestamp x y phi\n";
    char line[256];
    for (const auto& [id, pose] : graph.nodes) {
      const NodeScan& at = node_scans.at(id);
      std::snprintf(line, sizeof line, "%llu %zu %.6f %.9g %.9g %.9g\n",
                    static_cast<unsigned long long>(id), at.scan, at.timestamp_s, pose.x(),
                    pose.y(), pose.phi());
      out << line;
    }
    if (!out.flush()) throw std::runtime_error("cannot write " + tmp);
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string usage =
      "Usage: graphslam_lc INI PAIRS_RAWLOG OUT_NODES\n"
      "MRPT's CGraphSlamEngine (2D) with CFixedIntervalsNRD, CLoopCloserERD and CLevMarqGSO,\n"
      "headless, on an actions/sensory-frames rawlog (shape-slam convert --format pairs).\n"
      "Writes 'node scan timestamp x y phi' per node of the final graph to OUT_NODES.\n";
  if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::cout << usage;
    return 0;
  }
  if (argc != 4) {
    std::cerr << usage;
    return 2;
  }
  for (const char* path : {argv[1], argv[2]}) {
    if (!std::filesystem::is_regular_file(path)) {
      std::cerr << "graphslam_lc: error: no such file: " << path << "\n";
      return 2;
    }
  }
  try {
    const auto edge_reg = shape_slam::bench::MakeLoopCloser();
    auto node_reg = std::make_unique<mrpt::graphslam::deciders::CFixedIntervalsNRD<Graph>>();
    auto optimizer = std::make_unique<mrpt::graphslam::optimizers::CLevMarqGSO<Graph>>();
    mrpt::graphslam::CGraphSlamEngine<Graph> engine(argv[1], argv[2], "", nullptr, node_reg.get(),
                                                    edge_reg.get(), optimizer.get());
    const auto node_scans = Run(engine, argv[2]);
    WriteNodes(engine.getGraph(), node_scans, argv[3]);
  } catch (const std::exception& e) {
    std::cerr << "graphslam_lc: error: " << mrpt::exception_to_str(e) << "\n";
    return 1;
  }
  return 0;
}
