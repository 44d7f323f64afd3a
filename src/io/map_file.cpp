#include "shape_slam_io/map_file.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/json_writer.h"

namespace shape_slam::io {
namespace {

constexpr const char* kMagic = "shape-slam-polylines";
constexpr int kVersion = 1;
constexpr long long kMaxCount = 100000000;  // guards against absurd counts in corrupt files

// Reads the next non-comment, non-blank line, split into fields.
class LineReader {
 public:
  LineReader(const std::string& text, std::string name) : in_(text), name_(std::move(name)) {}

  std::vector<std::string> Next(const char* what) {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_number_;
      const std::size_t start = line.find_first_not_of(" \t\r");
      if (start == std::string::npos || line[start] == '#') continue;
      std::istringstream fields(line);
      std::vector<std::string> out;
      for (std::string f; fields >> f;) out.push_back(f);
      return out;
    }
    throw Error(std::string("unexpected end of file, expected ") + what);
  }

  bool AtEnd() {
    std::string rest;
    while (std::getline(in_, rest)) {
      ++line_number_;
      const std::size_t start = rest.find_first_not_of(" \t\r");
      if (start != std::string::npos && rest[start] != '#') return false;
    }
    return true;
  }

  MapFileError Error(const std::string& message) const {
    return MapFileError(name_ + ":" + std::to_string(line_number_) + ": " + message);
  }

  double Number(const std::string& field, const char* what) const {
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(field.c_str(), &end);
    if (field.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
      throw Error(std::string("bad ") + what + " '" + field + "'");
    }
    return value;
  }

  long long Count(const std::string& field, const char* what) const {
    const double value = Number(field, what);
    if (value < 0 || value > kMaxCount || value != std::floor(value)) {
      throw Error(std::string("bad ") + what + " '" + field + "'");
    }
    return static_cast<long long>(value);
  }

 private:
  std::istringstream in_;
  std::string name_;
  int line_number_ = 0;
};

MapPolyline ReadBlock(LineReader& reader) {
  const std::vector<std::string> header = reader.Next("a 'polyline' line");
  if (header.size() != 5 || header[0] != "polyline") {
    throw reader.Error("expected 'polyline ID VERTICES OBSERVATIONS CONTRADICTIONS'");
  }
  const long long vertices = reader.Count(header[2], "vertex count");
  if (vertices < 1) throw reader.Error("a polyline needs at least one vertex");
  MapPolyline polyline;
  polyline.observations = static_cast<int>(reader.Count(header[3], "observation count"));
  polyline.contradictions = static_cast<int>(reader.Count(header[4], "contradiction count"));
  for (long long v = 0; v < vertices; ++v) {
    const std::vector<std::string> fields = reader.Next("a vertex line 'x y support'");
    if (fields.size() != 3) throw reader.Error("expected 'x y support'");
    polyline.points.emplace_back(reader.Number(fields[0], "x"), reader.Number(fields[1], "y"));
    const double support = reader.Number(fields[2], "support");
    if (support < 0.0) throw reader.Error("negative support");
    polyline.support.push_back(support);
  }
  return polyline;
}

}  // namespace

std::string FormatMapFile(const PolylineMap& map) {
  std::ostringstream out;
  out << "# ShapeSLAM polyline map: map frame, metres (see include/shape_slam_io/map_file.h)\n"
      << kMagic << ' ' << kVersion << "\n"
      << "polylines " << map.NumPolylines() << "\n";
  for (const PolylineId id : map.Ids()) {
    const MapPolyline& p = map.Get(id);
    out << "polyline " << id << ' ' << p.points.size() << ' ' << p.observations << ' '
        << p.contradictions << "\n";
    for (std::size_t i = 0; i < p.points.size(); ++i) {
      out << FormatDouble(p.points[i].x()) << ' ' << FormatDouble(p.points[i].y()) << ' '
          << FormatDouble(p.support[i]) << "\n";
    }
  }
  return out.str();
}

void SaveMapFile(const std::string& path, const PolylineMap& map) {
  WriteFileAtomically(path, FormatMapFile(map));
}

PolylineMap ParseMapFile(const std::string& text, const std::string& name) {
  LineReader reader(text, name);
  const std::vector<std::string> magic = reader.Next("the format line");
  if (magic.size() != 2 || magic[0] != kMagic) {
    throw reader.Error(std::string("not a ShapeSLAM map file (expected '") + kMagic + " 1')");
  }
  if (magic[1] != std::to_string(kVersion)) {
    throw reader.Error("unsupported map file version " + magic[1]);
  }
  const std::vector<std::string> count = reader.Next("'polylines N'");
  if (count.size() != 2 || count[0] != "polylines") throw reader.Error("expected 'polylines N'");
  const long long n = reader.Count(count[1], "polyline count");
  PolylineMap map;
  for (long long i = 0; i < n; ++i) map.Add(ReadBlock(reader));
  if (!reader.AtEnd()) throw reader.Error("unexpected content after the last polyline");
  return map;
}

PolylineMap LoadMapFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw MapFileError(path + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapFileError(path + ": cannot open the map file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw MapFileError(path + ": read error");
  return ParseMapFile(text.str(), path);
}

}  // namespace shape_slam::io
