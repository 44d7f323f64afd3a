// CPolylineMap: 3D scene and files.
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/CSetOfObjects.h>

#include <string>

#include "polyline_geometry.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/map_file.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {

// The polylines as dark line segments at z = 0 (single-vertex polylines as zero-length ones).
void CPolylineMap::getVisualizationInto(mrpt::opengl::CSetOfObjects& outObj) const {
  if (!genericMapParams.enableSaveAs3DObject) return;
  auto lines = mrpt::opengl::CSetOfLines::Create();
  lines->setName("shape_slam::CPolylineMap");
  lines->setColor_u8(20, 20, 20);
  lines->setLineWidth(2.0f);
  for (const Polyline& p : Geometry().Polylines()) {
    if (p.size() == 1) lines->appendLine(p[0].x(), p[0].y(), 0.0, p[0].x(), p[0].y(), 0.0);
    for (std::size_t i = 0; i + 1 < p.size(); ++i) {
      lines->appendLine(p[i].x(), p[i].y(), 0.0, p[i + 1].x(), p[i + 1].y(), 0.0);
    }
  }
  outObj.insert(lines);
}

// `prefix.polylines` (the shape-slam map file) and `prefix.svg`. Throws io::OutputError naming
// the file when it cannot be written.
void CPolylineMap::saveMetricMapRepresentationToFile(const std::string& filNamePrefix) const {
  io::SaveMapFile(filNamePrefix + ".polylines", map_);
  const io::Drawing drawing = io::MakeMapDrawing(map_, std::vector<Point2>{}, "shape_slam::CPolylineMap");
  io::WriteFileAtomically(filNamePrefix + ".svg", io::RenderSvg(drawing));
}

}  // namespace shape_slam
