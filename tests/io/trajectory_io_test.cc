#include "shape_slam_io/trajectory_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io/test_files.h"

namespace shape_slam::io {
namespace {

using testing::TempDir;
using ::testing::HasSubstr;

TEST(TrajectoryIoTest, TumRoundTripIsExact) {
  const std::vector<StampedPose> trajectory = {{32.9068, Pose2(0.600266, -0.032033, -0.354665)},
                                               {1137783293.2456784, Pose2(-1e3, 2.5, 3.1)}};
  TempDir dir;
  const std::string path = dir.Write("t.tum", FormatTum(trajectory));
  const std::vector<StampedPose> read = ReadTrajectory(path);
  ASSERT_EQ(read.size(), 2u);
  for (std::size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].timestamp_s, trajectory[i].timestamp_s);  // bit-exact timestamps
    EXPECT_EQ(read[i].pose.x, trajectory[i].pose.x);
    EXPECT_EQ(read[i].pose.y, trajectory[i].pose.y);
    EXPECT_NEAR(read[i].pose.theta, trajectory[i].pose.theta, 1e-12);
  }
  // TUM layout: 8 fields, z = 0, unit quaternion about z.
  EXPECT_THAT(FormatTum({{1.5, Pose2(1, 2, 0)}}), HasSubstr("1.5 1 2 0 0 0 0 1\n"));
}

TEST(TrajectoryIoTest, ReadsReferencePosesAndRelations) {
  const std::string datasets = SHAPE_SLAM_DATASETS_DIR;
  const std::vector<StampedPose> gt = ReadTrajectory(datasets + "/radish/intel.gt.txt");
  ASSERT_EQ(gt.size(), 910u);
  EXPECT_DOUBLE_EQ(gt.front().timestamp_s, 32.9068);
  EXPECT_DOUBLE_EQ(gt.front().pose.theta, -0.354665);
  const std::vector<Relation> relations = ReadRelations(datasets + "/radish/intel.relations");
  ASSERT_FALSE(relations.empty());
  EXPECT_DOUBLE_EQ(relations.front().t2_s, 35.1051);
  EXPECT_DOUBLE_EQ(relations.front().T_1_2.theta, -0.584138);
}

TEST(TrajectoryIoTest, MalformedFilesNameTheLine) {
  TempDir dir;
  auto error_of = [&](const std::string& content) {
    const std::string path = dir.Write("bad.txt", content);
    try {
      ReadTrajectory(path);
    } catch (const TrajectoryFileError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error_of("# c\n1 2 3 4\n1 2 3\n"), HasSubstr("bad.txt:3: expected 4 fields"));
  EXPECT_THAT(error_of("1 2 nan 4\n"), HasSubstr("bad.txt:1: 'nan' is not a finite number"));
  EXPECT_THAT(error_of("1 2 x 4\n"), HasSubstr("'x' is not a finite number"));
  EXPECT_THAT(error_of("1 0 0 0 0.7 0 0 0.7\n"), HasSubstr("not a rotation about z"));
  EXPECT_THAT(error_of(""), HasSubstr("no poses"));
  EXPECT_THROW(ReadTrajectory(dir.Path("missing.txt")), TrajectoryFileError);
  EXPECT_THROW(ReadTrajectory(dir.path()), TrajectoryFileError);
  const std::string rel = dir.Write("r.txt", "1 2 0 0 0.5 0 0 0\n");
  EXPECT_THROW(ReadRelations(rel), TrajectoryFileError);
}

}  // namespace
}  // namespace shape_slam::io
