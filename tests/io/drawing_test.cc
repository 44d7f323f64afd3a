// RenderPng draws the picture in strips of rows and encodes it row by row: the file decodes (as
// a viewer reads it) to the picture's size, and a line crossing every strip's edge stays whole.
#include "shape_slam_io/drawing.h"

#include "shape_slam/polyline_map.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace shape_slam::io {
namespace {

// A picture 2 m wide and 30 m tall at 40 px per metre (1200 rows: several strips), a thick
// black diagonal from corner to corner, no title, no legend entries.
Drawing TallDiagonal() {
  Drawing drawing;
  drawing.margin_m = 0.0;
  drawing.layers.push_back({"", {{Point2(0.0, 0.0), Point2(2.0, 30.0)}}, {}, {0, 0, 0}, 3.0, 1.0, false});
  return drawing;
}

TEST(DrawingTest, PngDecodesToThePicturesSize) {
  const std::string png = RenderPng(TallDiagonal());
  const cv::Mat image = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << "not a PNG OpenCV reads";
  EXPECT_EQ(image.cols, 80);
  EXPECT_EQ(image.rows, 1200);
}

TEST(DrawingTest, ALineCrossingEveryStripStaysWhole) {
  const std::string png = RenderPng(TallDiagonal());
  const cv::Mat image = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
  ASSERT_EQ(image.rows, 1200);
  // Row r (from the top, y = 30 - r / 40 m) crosses the diagonal at x = y / 15 m. Every row away
  // from the scale bar and its label (bottom 40 rows) is dark there and light 0.5 m to the side.
  int dark_rows = 0;
  for (int r = 0; r < image.rows - 40; ++r) {
    const double x_px = (30.0 - (r + 0.5) / 40.0) / 15.0 * 40.0;
    const cv::Vec3b on = image.at<cv::Vec3b>(r, static_cast<int>(std::lround(x_px - 0.5)));
    const int side = static_cast<int>(x_px) + (x_px < 40.0 ? 20 : -20);
    const cv::Vec3b off = image.at<cv::Vec3b>(r, side);
    dark_rows += on[0] < 100 && on[1] < 100 && on[2] < 100 ? 1 : 0;
    EXPECT_GT(off[0] + off[1] + off[2], 3 * 200) << "row " << r;
  }
  EXPECT_EQ(dark_rows, image.rows - 40);
}

// A trajectory in pieces (localize: apart where the robot was not localized) is drawn piece by
// piece, never joined across a gap; start and end are the first and last points drawn.
TEST(DrawingTest, TrajectoryPiecesAreDrawnApart) {
  PolylineMap map;
  map.Add(MapPolyline{{Point2(0, 0), Point2(5, 0)}, {1.0, 1.0}});
  const std::vector<Polyline> pieces = {{Point2(1, 1), Point2(2, 1)},
                                        {},
                                        {Point2(3, 1)},
                                        {Point2(4, 2), Point2(4, 3), Point2(4.5, 3)}};
  const Drawing drawing = MakeMapDrawing(map, pieces, "pieces");
  const auto layer = [&](const std::string& name) -> const DrawingLayer& {
    for (const DrawingLayer& l : drawing.layers) {
      if (l.name == name) return l;
    }
    ADD_FAILURE() << "no layer " << name;
    return drawing.layers.front();
  };
  ASSERT_EQ(layer("trajectory").polylines.size(), 2u);  // the one-point piece is no line
  EXPECT_EQ(layer("trajectory").polylines[1], pieces[3]);
  EXPECT_EQ(layer("start").points.at(0), Point2(1, 1));
  EXPECT_EQ(layer("end").points.at(0), Point2(4.5, 3));
  EXPECT_EQ(layer("map polylines").polylines.size(), 1u);
  // One piece is the trajectory of `run`.
  const Drawing whole = MakeMapDrawing(map, pieces[3], "whole");
  EXPECT_EQ(whole.layers.front().polylines, std::vector<Polyline>{pieces[3]});
}

}  // namespace
}  // namespace shape_slam::io
