// Writes the observations-only rawlog fixtures used by tests/io/rawlog_reader_test.cc, made
// from the first 20 scans of MRPT's sample log (actions/sensory-frames layout, mrpt-common):
//
//   entry 0        CObservationComment (skipped by the readers)
//   entry 1        scan 0 (before any odometry: it has none)
//   entry 2k, 2k+1 for k = 1..19: CObservationOdometry (the absolute odometry of scan k, i.e.
//                  the product of the log's odometry increments up to it), then scan k
//
// Scans are paired with actions as CRawlog::getActionObservationPairOrObservation does, so
// scan k here is scan k of the sample log as MRPT's tools (and RawlogReader) read it.
// Outputs: sena_first20_obs_only.rawlog (gzip, as MRPT writes rawlogs) and
// sena_first20_obs_only_plain.rawlog (uncompressed).
//
// Rebuild (from the repository root; needs libmrpt-dev and mrpt-common):
//   cmake -S scripts/rawlog_fixtures -B /tmp/rawlog-fixtures -G Ninja
//   cmake --build /tmp/rawlog-fixtures
//   /tmp/rawlog-fixtures/make_rawlog_fixtures \
//     "/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog" \
//     tests/data/logs
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationComment.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/serialization/CArchive.h>

#include <iostream>
#include <string>
#include <vector>

namespace {

constexpr std::size_t kScans = 20;

std::vector<mrpt::serialization::CSerializable::Ptr> FixtureEntries(const std::string& source) {
  using namespace mrpt::obs;
  mrpt::io::CFileGZInputStream input(source);
  auto archive = mrpt::serialization::archiveFrom(input);
  std::vector<mrpt::serialization::CSerializable::Ptr> entries;
  auto comment = CObservationComment::Create();
  comment->text =
      "ShapeSLAM test fixture: first 20 scans of the MRPT sample log, "
      "observations-only layout (scripts/rawlog_fixtures)";
  comment->timestamp = mrpt::Clock::fromDouble(0.0);
  entries.push_back(comment);
  mrpt::poses::CPose2D odometry;
  CActionCollection::Ptr actions;
  CSensoryFrame::Ptr frame;
  CObservation::Ptr observation;
  std::size_t entry = 0;
  std::size_t scans = 0;
  while (scans < kScans && CRawlog::getActionObservationPairOrObservation(archive, actions, frame,
                                                                          observation, entry)) {
    if (!actions || !frame) continue;
    if (auto movement = actions->getBestMovementEstimation()) {
      odometry = odometry + movement->poseChange->getMeanVal();
    }
    auto scan = frame->getObservationByClass<CObservation2DRangeScan>();
    if (!scan) continue;
    if (scans > 0) {
      auto odometry_obs = CObservationOdometry::Create();
      odometry_obs->odometry = odometry;
      odometry_obs->timestamp = scan->timestamp;
      odometry_obs->sensorLabel = "ODOMETRY";
      entries.push_back(odometry_obs);
    }
    entries.push_back(scan);
    ++scans;
  }
  return entries;
}

template <typename Stream>
void Write(const std::string& path,
           const std::vector<mrpt::serialization::CSerializable::Ptr>& entries) {
  Stream output(path);
  auto archive = mrpt::serialization::archiveFrom(output);
  for (const auto& entry : entries) archive << *entry;
  std::cout << "wrote " << path << " (" << entries.size() << " entries)\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: make_rawlog_fixtures SAMPLE.rawlog OUTPUT_DIR\n";
    return 2;
  }
  const auto entries = FixtureEntries(argv[1]);
  const std::string dir = argv[2];
  Write<mrpt::io::CFileGZOutputStream>(dir + "/sena_first20_obs_only.rawlog", entries);
  Write<mrpt::io::CFileOutputStream>(dir + "/sena_first20_obs_only_plain.rawlog", entries);
  return 0;
}
