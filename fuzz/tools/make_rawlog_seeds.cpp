// Writes the seed rawlogs of the rawlog_reader fuzz target: small logs (a few KB) of both
// layouts that RawlogReader reads, so that the fuzzer starts from valid MRPT objects.
//
//   obs_only.rawlog        observations only: comment, scan without odometry, odometry, scan
//   obs_only.rawlog.gz     the same, gzip (as MRPT writes rawlogs)
//   actions_frames.rawlog  a sensory frame before any action (a scan at the odometry
//                          origin), then two (action collection, sensory frame) pairs
//   odd_scans.rawlog       a one-beam scan, a left-to-right scan with invalid readings, and a
//                          malformed scan (zero aperture) between them
//   sena_first2.rawlog     the first four entries of tests/data/logs/sena_first20_obs_only
//                          (two 361-beam scans of a real log)
//
// Rebuild (from the repository root; needs libmrpt-dev):
//   cmake -S fuzz/tools -B /tmp/rawlog-seeds -G Ninja && cmake --build /tmp/rawlog-seeds
//   /tmp/rawlog-seeds/make_rawlog_seeds tests/data/logs/sena_first20_obs_only_plain.rawlog \
//     fuzz/corpus/rawlog_reader
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationComment.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

namespace {

using Entries = std::vector<mrpt::serialization::CSerializable::Ptr>;
using namespace mrpt::obs;

CObservation2DRangeScan::Ptr Scan(std::size_t beams, double time_s, double aperture_rad) {
  auto scan = CObservation2DRangeScan::Create();
  scan->sensorLabel = "LASER";
  scan->timestamp = mrpt::Clock::fromDouble(time_s);
  scan->aperture = static_cast<float>(aperture_rad);
  scan->maxRange = 8.0f;
  scan->sensorPose = mrpt::poses::CPose3D(0.2, 0.0, 0.3, 0.0, 0.0, 0.0);
  scan->resizeScan(beams);
  for (std::size_t i = 0; i < beams; ++i) {
    scan->setScanRange(i, static_cast<float>(2.0 + 0.5 * std::sin(0.4 * static_cast<double>(i))));
    scan->setScanRangeValidity(i, true);
  }
  return scan;
}

CObservationOdometry::Ptr Odometry(double x, double y, double phi, double time_s) {
  auto odometry = CObservationOdometry::Create();
  odometry->sensorLabel = "ODOMETRY";
  odometry->timestamp = mrpt::Clock::fromDouble(time_s);
  odometry->odometry = mrpt::poses::CPose2D(x, y, phi);
  return odometry;
}

CActionCollection::Ptr Action(double dx, double dy, double dphi) {
  CActionRobotMovement2D movement;
  movement.computeFromOdometry(mrpt::poses::CPose2D(dx, dy, dphi),
                               CActionRobotMovement2D::TMotionModelOptions());
  auto actions = CActionCollection::Create();
  actions->insert(movement);
  return actions;
}

CSensoryFrame::Ptr Frame(const CObservation::Ptr& observation) {
  auto frame = CSensoryFrame::Create();
  frame->insert(observation);
  return frame;
}

Entries ObservationsOnly() {
  auto comment = CObservationComment::Create();
  comment->text = "ShapeSLAM fuzz seed";
  comment->timestamp = mrpt::Clock::fromDouble(1.0);
  return {comment, Scan(16, 1.0, M_PI), Odometry(0.5, -0.25, 0.1, 1.1), Scan(16, 1.1, M_PI)};
}

Entries ActionsAndFrames() {
  return {Frame(Scan(8, 1.0, M_PI)), Action(0.1, 0.0, 0.05), Frame(Scan(12, 2.0, 1.5 * M_PI)),
          Action(0.2, 0.1, -0.1), Frame(Scan(12, 3.0, 1.5 * M_PI))};
}

Entries OddScans() {
  auto left_to_right = Scan(6, 2.0, M_PI);
  left_to_right->rightToLeft = false;
  left_to_right->setScanRangeValidity(1, false);
  left_to_right->setScanRange(2, -1.0f);
  left_to_right->setScanRange(3, 100.0f);
  return {Scan(1, 1.0, 0.5), Scan(4, 1.5, 0.0), left_to_right, Odometry(1.0, 2.0, 3.0, 2.5)};
}

// The first `count` entries of an existing rawlog.
Entries FirstEntries(const std::string& path, std::size_t count) {
  mrpt::io::CFileGZInputStream input(path);
  auto archive = mrpt::serialization::archiveFrom(input);
  Entries entries;
  for (std::size_t i = 0; i < count; ++i) entries.push_back(archive.ReadObject());
  return entries;
}

template <typename Stream>
void Write(const std::string& path, const Entries& entries) {
  Stream output(path);
  auto archive = mrpt::serialization::archiveFrom(output);
  for (const auto& entry : entries) archive << *entry;
  std::cout << "wrote " << path << " (" << entries.size() << " entries)\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: make_rawlog_seeds SENA_FIXTURE.rawlog OUTPUT_DIR\n";
    return 2;
  }
  const std::string dir = argv[2];
  Write<mrpt::io::CFileOutputStream>(dir + "/obs_only.rawlog", ObservationsOnly());
  Write<mrpt::io::CFileGZOutputStream>(dir + "/obs_only.rawlog.gz", ObservationsOnly());
  Write<mrpt::io::CFileOutputStream>(dir + "/actions_frames.rawlog", ActionsAndFrames());
  Write<mrpt::io::CFileOutputStream>(dir + "/odd_scans.rawlog", OddScans());
  Write<mrpt::io::CFileOutputStream>(dir + "/sena_first2.rawlog", FirstEntries(argv[1], 4));
  return 0;
}
