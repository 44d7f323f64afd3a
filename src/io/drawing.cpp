#include "shape_slam_io/drawing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string_view>
#include <zlib.h>

#include "deflate_internal.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/json_writer.h"

namespace shape_slam::io {
namespace {

// Pixel frame of a drawing: world bounds, scale and the world->pixel mapping (y flipped). A PNG
// is drawn in strips of rows: offset_y is the first row of the strip being drawn.
struct Viewport {
  double min_x = 0, min_y = 0, max_x = 1, max_y = 1;
  double scale = 40.0;  // px per metre
  int width = 1, height = 1;
  int offset_y = 0;

  double Px(double x) const { return (x - min_x) * scale; }
  double Py(double y) const { return (max_y - y) * scale - offset_y; }
};

Viewport MakeViewport(const Drawing& drawing) {
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  auto grow = [&](const Point2& p) {
    if (!p.allFinite()) return;
    min_x = std::min(min_x, p.x());
    min_y = std::min(min_y, p.y());
    max_x = std::max(max_x, p.x());
    max_y = std::max(max_y, p.y());
  };
  for (const DrawingLayer& layer : drawing.layers) {
    for (const Polyline& line : layer.polylines) std::for_each(line.begin(), line.end(), grow);
    std::for_each(layer.points.begin(), layer.points.end(), grow);
  }
  if (!(min_x <= max_x)) min_x = min_y = 0.0, max_x = max_y = 1.0;
  Viewport v;
  v.min_x = std::floor(min_x - drawing.margin_m);
  v.min_y = std::floor(min_y - drawing.margin_m);
  v.max_x = std::ceil(max_x + drawing.margin_m);
  v.max_y = std::ceil(max_y + drawing.margin_m);
  const double span = std::max(v.max_x - v.min_x, v.max_y - v.min_y);
  v.scale = std::min(drawing.pixels_per_m, drawing.max_size_px / span);
  v.width = std::max(1, static_cast<int>(std::ceil((v.max_x - v.min_x) * v.scale)));
  v.height = std::max(1, static_cast<int>(std::ceil((v.max_y - v.min_y) * v.scale)));
  return v;
}

std::string Hex(const Color& c) {
  static const char* kHex = "0123456789abcdef";
  std::string s = "#";
  for (const std::uint8_t channel : {c.r, c.g, c.b}) {
    s += kHex[channel >> 4];
    s += kHex[channel & 15];
  }
  return s;
}

std::string XmlEscape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Num(double value) { return FormatDouble(std::round(value * 100.0) / 100.0); }

// Length of the scale bar: the largest of 1, 2, 5, 10, 20, 50 m that fits a fifth of the width.
double ScaleBarLength(const Viewport& v) {
  double best = 1.0;
  for (const double candidate : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0}) {
    if (candidate * v.scale <= v.width / 5.0) best = candidate;
  }
  return best;
}

void SvgGrid(const Drawing& drawing, const Viewport& v, std::ostringstream& svg) {
  svg << "<g stroke=\"#e4e4e4\" stroke-width=\"1\">\n";
  const double step = drawing.grid_spacing_m;
  for (double x = std::ceil(v.min_x / step) * step; x <= v.max_x; x += step) {
    svg << "<line x1=\"" << Num(v.Px(x)) << "\" y1=\"0\" x2=\"" << Num(v.Px(x)) << "\" y2=\""
        << v.height << "\"/>\n";
  }
  for (double y = std::ceil(v.min_y / step) * step; y <= v.max_y; y += step) {
    svg << "<line x1=\"0\" y1=\"" << Num(v.Py(y)) << "\" x2=\"" << v.width << "\" y2=\""
        << Num(v.Py(y)) << "\"/>\n";
  }
  svg << "</g>\n";
}

void SvgLayer(const DrawingLayer& layer, const Viewport& v, std::ostringstream& svg) {
  const std::string color = Hex(layer.color);
  svg << "<g fill=\"none\" stroke=\"" << color << "\" stroke-width=\"" << Num(layer.line_width_px)
      << "\" stroke-linejoin=\"round\" stroke-linecap=\"round\">\n";
  for (const Polyline& line : layer.polylines) {
    if (line.size() < 2) continue;
    svg << "<polyline points=\"";
    for (const Point2& p : line) svg << Num(v.Px(p.x())) << ',' << Num(v.Py(p.y())) << ' ';
    svg << "\"/>\n";
  }
  svg << "</g>\n<g fill=\"" << color << "\" stroke=\"none\">\n";
  auto dot = [&](const Point2& p, double r) {
    svg << "<circle cx=\"" << Num(v.Px(p.x())) << "\" cy=\"" << Num(v.Py(p.y())) << "\" r=\""
        << Num(r) << "\"/>\n";
  };
  for (const Point2& p : layer.points) dot(p, layer.point_radius_px);
  if (layer.mark_vertices) {
    for (const Polyline& line : layer.polylines) {
      for (const Point2& p : line) dot(p, layer.line_width_px * 1.5);
    }
  }
  svg << "</g>\n";
}

void SvgLegendAndScale(const Drawing& drawing, const Viewport& v, std::ostringstream& svg) {
  const double bar = ScaleBarLength(v);
  const double y = v.height - 12.0;
  svg << "<g font-family=\"sans-serif\" font-size=\"12\">\n";
  svg << "<line x1=\"10\" y1=\"" << Num(y) << "\" x2=\"" << Num(10 + bar * v.scale) << "\" y2=\""
      << Num(y) << "\" stroke=\"black\" stroke-width=\"3\"/>\n";
  svg << "<text x=\"10\" y=\"" << Num(y - 6) << "\">" << FormatDouble(bar) << " m</text>\n";
  double ly = 16.0;
  if (!drawing.title.empty()) {
    svg << "<text x=\"10\" y=\"" << Num(ly) << "\" font-weight=\"bold\">" << XmlEscape(drawing.title)
        << "</text>\n";
    ly += 16.0;
  }
  for (const DrawingLayer& layer : drawing.layers) {
    if (layer.name.empty()) continue;
    svg << "<rect x=\"10\" y=\"" << Num(ly - 9) << "\" width=\"14\" height=\"4\" fill=\""
        << Hex(layer.color) << "\"/><text x=\"30\" y=\"" << Num(ly) << "\">" << XmlEscape(layer.name)
        << "</text>\n";
    ly += 16.0;
  }
  svg << "</g>\n";
}

cv::Scalar Bgr(const Color& c) { return cv::Scalar(c.b, c.g, c.r); }

// Fixed-point coordinates (4 fractional bits) give OpenCV sub-pixel antialiased lines.
constexpr int kShift = 4;
cv::Point Fixed(const Viewport& v, const Point2& p) {
  return {static_cast<int>(std::lround(v.Px(p.x()) * (1 << kShift))),
          static_cast<int>(std::lround(v.Py(p.y()) * (1 << kShift)))};
}

void PngLayer(const DrawingLayer& layer, const Viewport& v, cv::Mat& image) {
  const int thickness = std::max(1, static_cast<int>(std::lround(layer.line_width_px)));
  for (const Polyline& line : layer.polylines) {
    std::vector<cv::Point> pts;
    for (const Point2& p : line) {
      if (p.allFinite()) pts.push_back(Fixed(v, p));
    }
    if (pts.size() >= 2) {
      cv::polylines(image, pts, false, Bgr(layer.color), thickness, cv::LINE_AA, kShift);
    }
    if (layer.mark_vertices) {
      for (const cv::Point& p : pts) {
        cv::circle(image, p, (thickness + 1) << kShift, Bgr(layer.color), -1, cv::LINE_AA, kShift);
      }
    }
  }
  const int radius = static_cast<int>(std::lround(layer.point_radius_px * (1 << kShift)));
  for (const Point2& p : layer.points) {
    if (p.allFinite()) cv::circle(image, Fixed(v, p), radius, Bgr(layer.color), -1, cv::LINE_AA, kShift);
  }
}

void PngDecorations(const Drawing& drawing, const Viewport& v, cv::Mat& image) {
  const double bar = ScaleBarLength(v);
  const int y = v.height - 12 - v.offset_y;
  cv::line(image, {10, y}, {10 + static_cast<int>(bar * v.scale), y}, cv::Scalar(0, 0, 0), 3);
  cv::putText(image, FormatDouble(bar) + " m", {10, y - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  int ly = 18 - v.offset_y;
  if (!drawing.title.empty()) {
    cv::putText(image, drawing.title, {10, ly}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0),
                1, cv::LINE_AA);
    ly += 18;
  }
  for (const DrawingLayer& layer : drawing.layers) {
    if (layer.name.empty()) continue;
    cv::rectangle(image, {10, ly - 7}, {24, ly - 3}, Bgr(layer.color), -1);
    cv::putText(image, layer.name, {30, ly}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    ly += 18;
  }
}

}  // namespace

std::string RenderSvg(const Drawing& drawing) {
  const Viewport v = MakeViewport(drawing);
  std::ostringstream svg;
  svg << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << v.width << "\" height=\""
      << v.height << "\" viewBox=\"0 0 " << v.width << ' ' << v.height << "\">\n"
      << "<!-- world frame: x right, y up; " << Num(v.scale) << " px per metre; grid "
      << FormatDouble(drawing.grid_spacing_m) << " m; origin at pixel (" << Num(v.Px(0)) << ", "
      << Num(v.Py(0)) << ") -->\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  SvgGrid(drawing, v, svg);
  for (const DrawingLayer& layer : drawing.layers) SvgLayer(layer, v, svg);
  SvgLegendAndScale(drawing, v, svg);
  svg << "</svg>\n";
  return svg.str();
}

namespace {

// The grid, the layers and the decorations, in the rows of `image` (v.offset_y on).
void DrawPng(const Drawing& drawing, const Viewport& v, cv::Mat& image) {
  const double step = drawing.grid_spacing_m;
  const cv::Scalar grid(228, 228, 228);
  for (double x = std::ceil(v.min_x / step) * step; x <= v.max_x; x += step) {
    const int px = static_cast<int>(std::lround(v.Px(x)));
    cv::line(image, {px, 0}, {px, v.height}, grid, 1);
  }
  for (double y = std::ceil(v.min_y / step) * step; y <= v.max_y; y += step) {
    const int py = static_cast<int>(std::lround(v.Py(y)));
    cv::line(image, {0, py}, {v.width, py}, grid, 1);
  }
  for (const DrawingLayer& layer : drawing.layers) PngLayer(layer, v, image);
  PngDecorations(drawing, v, image);
}

// An 8-bit RGB PNG written row by row (zlib's deflate, no row filter): the picture never has to
// be whole in memory.
class PngEncoder {
 public:
  PngEncoder(int width, int height) : width_(width) {
    out_ = std::string("\x89PNG\r\n\x1a\n", 8);
    std::string header;
    Put32(header, static_cast<std::uint32_t>(width));
    Put32(header, static_cast<std::uint32_t>(height));
    header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, no filter, no interlace
    Chunk("IHDR", header);
    if (deflateInit(&z_, Z_BEST_SPEED) != Z_OK) throw OutputError("PNG encoding failed");
  }
  ~PngEncoder() { deflateEnd(&z_); }
  PngEncoder(const PngEncoder&) = delete;
  PngEncoder& operator=(const PngEncoder&) = delete;

  /// Rows of a BGR image (OpenCV's order), `width` pixels wide.
  void AddRows(const cv::Mat& bgr) {
    std::string row(1 + 3 * static_cast<std::size_t>(width_), '\0');  // filter byte 0: none
    for (int r = 0; r < bgr.rows; ++r) {
      const std::uint8_t* p = bgr.ptr<std::uint8_t>(r);
      for (int x = 0; x < width_; ++x) {
        row[1 + 3 * x] = static_cast<char>(p[3 * x + 2]);
        row[2 + 3 * x] = static_cast<char>(p[3 * x + 1]);
        row[3 + 3 * x] = static_cast<char>(p[3 * x]);
      }
      Deflate(row, Z_NO_FLUSH);
    }
  }
  std::string Finish() {
    Deflate({}, Z_FINISH);
    Chunk("IEND", {});
    return std::move(out_);
  }

 private:
  static void Put32(std::string& s, std::uint32_t v) {
    for (const int shift : {24, 16, 8, 0}) s += static_cast<char>((v >> shift) & 0xff);
  }
  void Chunk(const char* type, std::string_view data) {
    Put32(out_, static_cast<std::uint32_t>(data.size()));
    const std::size_t start = out_.size();
    out_ += type;
    out_ += data;
    const auto* bytes = reinterpret_cast<const Bytef*>(out_.data() + start);
    Put32(out_, static_cast<std::uint32_t>(crc32(0L, bytes, static_cast<uInt>(out_.size() - start))));
  }
  // Compresses `in` into IDAT chunks of up to 64 KiB; Z_FINISH flushes the stream.
  void Deflate(std::string_view in, int flush) {
    internal::DeflateInto(z_, in, flush, "PNG encoding failed",
                          [&](std::string_view block) { Chunk("IDAT", block); });
  }

  int width_;
  z_stream z_{};
  std::string out_;
};

// Strips of this many rows, each drawn with kStripPad rows more on either side so that lines
// cut at a strip's edge are cut away from the rows kept.
constexpr int kStripRows = 256;
constexpr int kStripPad = 16;

}  // namespace

std::string RenderPng(const Drawing& drawing) {
  const Viewport whole = MakeViewport(drawing);
  PngEncoder png(whole.width, whole.height);
  for (int y0 = 0; y0 < whole.height; y0 += kStripRows) {
    const int rows = std::min(kStripRows, whole.height - y0);
    const int top = std::max(0, y0 - kStripPad);
    const int bottom = std::min(whole.height, y0 + rows + kStripPad);
    Viewport v = whole;
    v.offset_y = top;
    cv::Mat strip(bottom - top, whole.width, CV_8UC3, cv::Scalar(255, 255, 255));
    DrawPng(drawing, v, strip);
    png.AddRows(strip.rowRange(y0 - top, y0 - top + rows));
  }
  return png.Finish();
}

}  // namespace shape_slam::io

namespace shape_slam::io {

Drawing MakeMapDrawing(const PolylineMap& map, const std::vector<Point2>& trajectory,
                       const std::string& title) {
  return MakeMapDrawing(map, std::vector<Polyline>{trajectory}, title);
}

Drawing MakeMapDrawing(const PolylineMap& map, const std::vector<Polyline>& trajectory_pieces,
                       const std::string& title) {
  Drawing drawing;
  drawing.title = title;
  DrawingLayer walls{"map polylines", map.Polylines(), {}, {20, 20, 20}, 1.6, 1.0, false};
  DrawingLayer path{"trajectory", {}, {}, {40, 100, 220}, 1.0, 1.0, false};
  const Point2* start = nullptr;
  const Point2* end = nullptr;
  for (const Polyline& piece : trajectory_pieces) {
    if (piece.size() >= 2) path.polylines.push_back(piece);
    if (piece.empty()) continue;
    if (start == nullptr) start = &piece.front();
    end = &piece.back();
  }
  drawing.layers.push_back(std::move(path));
  drawing.layers.push_back(std::move(walls));
  if (start != nullptr) {
    drawing.layers.push_back({"start", {}, {*start}, {0, 160, 0}, 1.0, 4.0, false});
    drawing.layers.push_back({"end", {}, {*end}, {220, 0, 0}, 1.0, 4.0, false});
  }
  return drawing;
}

}  // namespace shape_slam::io
