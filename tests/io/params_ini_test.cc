// The parameter ini (params_ini.h): config/default.ini is exactly the defaults, formatting and
// parsing round-trip, and every kind of broken ini is an error naming the key.
#include "shape_slam_io/params_ini.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io/test_files.h"

namespace shape_slam::io {
namespace {

using ::testing::HasSubstr;

std::string ErrorOf(const std::string& text) {
  try {
    ParseParamsIni(text, "test.ini");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(ParamsIniTest, DefaultIniInTheRepositoryIsTheDefaults) {
  const std::string file = testing::ReadFile(SHAPE_SLAM_DATASETS_DIR "/../config/default.ini");
  EXPECT_EQ(file, FormatParamsIni(ShapeSlamParams{}))
      << "regenerate it: shape-slam run --print-config > config/default.ini";
}

TEST(ParamsIniTest, FormatThenParseRoundTrips) {
  ShapeSlamParams p;
  p.shapes.dce.threshold_m = 0.0731;
  p.use_odometry = false;
  p.loop_closure.max_candidates = 7;
  p.matcher.skip_penalty_per_m = 1.0 / 3.0;
  p.scan_match_seeds = 4;
  const std::string text = FormatParamsIni(p);
  const ShapeSlamParams q = ParseParamsIni(text, "round-trip.ini");
  EXPECT_EQ(q.shapes.dce.threshold_m, p.shapes.dce.threshold_m);
  EXPECT_EQ(q.use_odometry, false);
  EXPECT_EQ(q.loop_closure.max_candidates, 7);
  EXPECT_EQ(q.matcher.skip_penalty_per_m, p.matcher.skip_penalty_per_m);  // bit-exact
  EXPECT_EQ(FormatParamsIni(q), text);
}

TEST(ParamsIniTest, MissingKeysKeepTheirDefaultsAndCommentsAreIgnored) {
  const ShapeSlamParams p =
      ParseParamsIni("# comment\n[dce]\nthreshold_m = 0.08  ; inline\n\n", "x.ini");
  EXPECT_EQ(p.shapes.dce.threshold_m, 0.08);
  EXPECT_EQ(p.shapes.extraction.max_gap_m, ShapeSlamParams{}.shapes.extraction.max_gap_m);
}

TEST(ParamsIniTest, BrokenIniFilesNameTheProblem) {
  EXPECT_THAT(ErrorOf("[dce]\nthreshhold_m = 0.1\n"), HasSubstr("threshhold_m"));
  EXPECT_THAT(ErrorOf("[nosuchsection]\nx = 1\n"), HasSubstr("nosuchsection"));
  EXPECT_THAT(ErrorOf("[dce]\nthreshold_m = abc\n"), HasSubstr("threshold_m"));
  EXPECT_THAT(ErrorOf("[dce]\nthreshold_m = nan\n"), HasSubstr("threshold_m"));
  EXPECT_THAT(ErrorOf("[dce]\nthreshold_m = -1\n"), HasSubstr("threshold_m"));
  EXPECT_THAT(ErrorOf("[dce]\nthreshold_m = 0.1\nthreshold_m = 0.2\n"), HasSubstr("threshold_m"));
  EXPECT_THAT(ErrorOf("[pipeline]\nuse_odometry = maybe\n"), HasSubstr("use_odometry"));
  EXPECT_THAT(ErrorOf("[extraction]\nmin_points = 2.5\n"), HasSubstr("min_points"));
  EXPECT_THAT(ErrorOf("threshold_m = 0.1\n"), HasSubstr("threshold_m"));  // outside a section
  EXPECT_THAT(ErrorOf("[dce\nthreshold_m = 0.1\n"), HasSubstr("test.ini:1"));
  EXPECT_THAT(ErrorOf("[dce]\njust some words\n"), HasSubstr("test.ini:2"));
}

TEST(ParamsIniTest, MissingFileIsAConfigError) {
  EXPECT_THROW(LoadParamsIni("/nonexistent/dir/x.ini"), ConfigError);
  testing::TempDir dir;
  EXPECT_THROW(LoadParamsIni(dir.path()), ConfigError);
}

}  // namespace
}  // namespace shape_slam::io
