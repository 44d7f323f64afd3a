// The parameter ini (params_ini.h): config/default.ini is exactly the defaults (the mapper's and
// the localizer's), formatting and parsing round-trip, and every kind of broken ini is an error
// naming the key.
#include "shape_slam_io/params_ini.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io/test_files.h"

namespace shape_slam::io {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

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

// [localizer]: LocalizerParams' own fields, read with the mapper's stages from one file.
TEST(ParamsIniTest, LocalizerKeysSetTheLocalizerAndTheStagesStayTheMappers) {
  const LocalizerParams p = ParseLocalizerParamsIni(
      "[localizer]\nmin_global_fit = 0.75\nlost_after_scans = 5\n[dce]\nthreshold_m = 0.07\n",
      "loc.ini");
  EXPECT_EQ(p.min_global_fit, 0.75);
  EXPECT_EQ(p.lost_after_scans, 5);
  EXPECT_EQ(p.stages.shapes.dce.threshold_m, 0.07);
  EXPECT_EQ(p.global_tile_half_m, LocalizerParams{}.global_tile_half_m);  // not given: default
  // The mapper's reader accepts (and checks) the section too: one file serves both commands.
  EXPECT_EQ(ParseParamsIni("[localizer]\nmin_global_fit = 0.75\n", "x.ini").shapes.dce.threshold_m,
            ShapeSlamParams{}.shapes.dce.threshold_m);
}

TEST(ParamsIniTest, LocalizerRoundTripsAndItsDefaultsAreInTheDefaultIni) {
  LocalizerParams p;
  p.evidence_decay = 0.55;
  p.max_hypotheses = 6;
  p.stages.use_odometry = false;
  const std::string text = FormatParamsIni(p);
  EXPECT_THAT(text, HasSubstr("[localizer]\n"));
  const LocalizerParams q = ParseLocalizerParamsIni(text, "round-trip.ini");
  EXPECT_EQ(q.evidence_decay, 0.55);
  EXPECT_EQ(q.max_hypotheses, 6);
  EXPECT_FALSE(q.stages.use_odometry);
  EXPECT_EQ(FormatParamsIni(q), text);
  EXPECT_EQ(FormatParamsIni(LocalizerParams{}), FormatParamsIni(ShapeSlamParams{}));
}

// The keys of the deleted global-map design are refused with a note saying why.
TEST(ParamsIniTest, KeysOfTheDeletedGlobalMapDesignSayWhy) {
  for (const std::string key : {"[submaps]\nenabled = false\n",
                                "[loop_closure]\nrebuild_checkpoint_every = 64\n",
                                "[loop_closure]\ndeform_max_shift_m = 0.15\n"}) {
    EXPECT_THAT(ErrorOf(key), HasSubstr("removed with the global-map design")) << key;
  }
  EXPECT_THAT(ErrorOf("[submaps]\nenabledd = false\n"),
              Not(HasSubstr("removed with the global-map design")));
}

TEST(ParamsIniTest, BrokenLocalizerKeysNameTheKeyAndTheField) {
  EXPECT_THAT(ErrorOf("[localizer]\nmin_global_fitt = 0.5\n"),
              HasSubstr("unknown key 'min_global_fitt' in [localizer]"));
  EXPECT_THAT(ErrorOf("[localizer]\nmax_hypotheses = many\n"),
              HasSubstr("localizer.max_hypotheses = 'many': expected an integer"));
  EXPECT_THAT(ErrorOf("[localizer]\nmin_global_fit = 1.5\n"),
              HasSubstr("LocalizerParams::min_global_fit must be in [0"));
  EXPECT_THAT(ErrorOf("[localizer]\nlost_after_scans = 0\n"),
              HasSubstr("LocalizerParams::lost_after_scans must be >= 1"));
  try {
    ParseLocalizerParamsIni("[localizer]\ndistinct_rad = -1\n", "loc.ini");
    ADD_FAILURE() << "a negative distinct_rad was accepted";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("loc.ini: invalid parameters: LocalizerParams::distinct_rad"));
  }
}

TEST(ParamsIniTest, MissingFileIsAConfigError) {
  EXPECT_THROW(LoadParamsIni("/nonexistent/dir/x.ini"), ConfigError);
  testing::TempDir dir;
  EXPECT_THROW(LoadParamsIni(dir.path()), ConfigError);
  EXPECT_THROW(LoadLocalizerParamsIni("/nonexistent/dir/x.ini"), ConfigError);
}

}  // namespace
}  // namespace shape_slam::io
