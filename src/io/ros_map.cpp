#include "shape_slam_io/ros_map.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "log_reader_internal.h"
#include "shape_slam_io/map_file.h"

namespace shape_slam::io {
namespace {

unsigned char PixelOf(CellState state) {
  switch (state) {
    case CellState::kOccupied: return kPgmOccupied;
    case CellState::kFree: return kPgmFree;
    case CellState::kUnknown: break;
  }
  return kPgmUnknown;
}

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapFileError(path + ": cannot open");
  std::ostringstream content;
  content << in.rdbuf();
  return content.str();
}

/// "key: value" lines of a flat YAML file (comments and blank lines ignored).
std::map<std::string, std::string> ParseFlatYaml(const std::string& text) {
  std::map<std::string, std::string> values;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    line = line.substr(0, line.find('#'));
    const std::string::size_type colon = line.find(':');
    if (colon == std::string::npos) continue;
    auto trim = [](std::string s) {
      const auto first = s.find_first_not_of(" \t\r\"'");
      const auto last = s.find_last_not_of(" \t\r\"'");
      return first == std::string::npos ? std::string() : s.substr(first, last - first + 1);
    };
    values[trim(line.substr(0, colon))] = trim(line.substr(colon + 1));
  }
  return values;
}

double Number(const std::map<std::string, std::string>& yaml, const std::string& key,
              const std::string& path) {
  const auto it = yaml.find(key);
  if (it == yaml.end()) throw MapFileError(path + ": no '" + key + "'");
  std::istringstream in(it->second);
  double value = 0.0;
  if (!(in >> value) || !std::isfinite(value)) {
    throw MapFileError(path + ": '" + key + "' is not a number: " + it->second);
  }
  return value;
}

struct PgmImage {
  int width = 0, height = 0, max_value = 0;
  std::vector<int> pixels;  // row-major, first row on top
};

/// A P5 (binary) or P2 (text) PGM; header comments allowed.
PgmImage ParsePgm(const std::string& data, const std::string& path) {
  std::istringstream in(data);
  std::string magic;
  in >> magic;
  if (magic != "P5" && magic != "P2") throw MapFileError(path + ": not a PGM image (P5 or P2)");
  PgmImage image;
  int* fields[] = {&image.width, &image.height, &image.max_value};
  for (int* field : fields) {
    while (in >> std::ws && in.peek() == '#') in.ignore(1 << 20, '\n');
    if (!(in >> *field) || *field <= 0) throw MapFileError(path + ": malformed PGM header");
  }
  if (image.max_value > 255) throw MapFileError(path + ": 16-bit PGM is not supported");
  const std::size_t count = static_cast<std::size_t>(image.width) * image.height;
  image.pixels.resize(count);
  if (magic == "P5") {
    in.get();  // the single whitespace after the header
    const std::size_t start = static_cast<std::size_t>(in.tellg());
    if (data.size() < start + count) throw MapFileError(path + ": PGM pixel data is truncated");
    for (std::size_t i = 0; i < count; ++i) {
      image.pixels[i] = static_cast<unsigned char>(data[start + i]);
    }
  } else {
    for (int& pixel : image.pixels) {
      if (!(in >> pixel)) throw MapFileError(path + ": PGM pixel data is truncated");
    }
  }
  return image;
}

std::string PgmHeader(const OccupancyGrid& grid) {
  return "P5\n# shape-slam occupancy grid, resolution " +
         internal::FormatNumber(grid.resolution_m) + " m\n" + std::to_string(grid.width) + " " +
         std::to_string(grid.height) + "\n255\n";
}

}  // namespace

void WritePgm(const OccupancyGrid& grid, const ByteWriter& write) {
  write(PgmHeader(grid));
  std::string pixels(static_cast<std::size_t>(std::max(grid.width, 0)), '\0');
  for (int row = 0; row < grid.height; ++row) {
    const int iy = grid.height - 1 - row;  // the first row is the top (highest y)
    for (int ix = 0; ix < grid.width; ++ix) pixels[ix] = static_cast<char>(PixelOf(grid.At(ix, iy)));
    write(pixels);
  }
}

std::string FormatPgm(const OccupancyGrid& grid) {
  std::string pgm;
  pgm.reserve(PgmHeader(grid).size() + grid.cells.size());
  WritePgm(grid, [&](std::string_view bytes) { pgm.append(bytes); });
  return pgm;
}

void ReadPgmRows(const std::string& path, const OccupancyGrid& frame,
                 const std::function<void(int iy, const std::vector<CellState>& cells)>& row) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapFileError(path + ": cannot open");
  const std::string header = PgmHeader(frame);
  std::string read(header.size(), '\0');
  if (!in.read(read.data(), static_cast<std::streamsize>(read.size())) || read != header) {
    throw MapFileError(path + ": not the PGM written for a grid of " +
                       std::to_string(frame.width) + " x " + std::to_string(frame.height) +
                       " cells");
  }
  std::string pixels(static_cast<std::size_t>(std::max(frame.width, 0)), '\0');
  std::vector<CellState> cells(pixels.size());
  for (int iy = frame.height - 1; iy >= 0; --iy) {
    if (!in.read(pixels.data(), static_cast<std::streamsize>(pixels.size()))) {
      throw MapFileError(path + ": PGM pixel data is truncated");
    }
    for (std::size_t ix = 0; ix < pixels.size(); ++ix) {
      const auto pixel = static_cast<unsigned char>(pixels[ix]);
      if (pixel == kPgmOccupied) {
        cells[ix] = CellState::kOccupied;
      } else if (pixel == kPgmFree) {
        cells[ix] = CellState::kFree;
      } else if (pixel == kPgmUnknown) {
        cells[ix] = CellState::kUnknown;
      } else {
        throw MapFileError(path + ": pixel value " + std::to_string(pixel) +
                           " is none of occupied, free, unknown");
      }
    }
    row(iy, cells);
  }
}

std::string FormatMapYaml(const OccupancyGrid& grid, const std::string& image_file) {
  return "image: " + image_file + "\nresolution: " + internal::FormatNumber(grid.resolution_m) +
         "\norigin: [" + internal::FormatNumber(grid.origin_m.x()) + ", " +
         internal::FormatNumber(grid.origin_m.y()) +
         ", 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
}

OccupancyGrid LoadRosMap(const std::string& yaml_path) {
  const std::map<std::string, std::string> yaml = ParseFlatYaml(ReadWholeFile(yaml_path));
  const auto image_it = yaml.find("image");
  if (image_it == yaml.end()) throw MapFileError(yaml_path + ": no 'image'");
  std::filesystem::path image_path(image_it->second);
  if (image_path.is_relative()) {
    image_path = std::filesystem::path(yaml_path).parent_path() / image_path;
  }
  OccupancyGrid grid;
  grid.resolution_m = Number(yaml, "resolution", yaml_path);
  const auto origin_it = yaml.find("origin");
  std::istringstream origin(origin_it == yaml.end() ? "" : origin_it->second);
  char bracket = 0, comma = 0;
  if (!(origin >> bracket >> grid.origin_m.x() >> comma >> grid.origin_m.y()) || bracket != '[') {
    throw MapFileError(yaml_path + ": 'origin' is not [x, y, yaw]");
  }
  const bool negate = Number(yaml, "negate", yaml_path) != 0.0;
  const double occupied = Number(yaml, "occupied_thresh", yaml_path);
  const double free = Number(yaml, "free_thresh", yaml_path);
  const PgmImage image = ParsePgm(ReadWholeFile(image_path.string()), image_path.string());
  grid.width = image.width;
  grid.height = image.height;
  grid.cells.resize(image.pixels.size());
  for (int row = 0; row < image.height; ++row) {
    for (int ix = 0; ix < image.width; ++ix) {
      const double v = image.pixels[static_cast<std::size_t>(row) * image.width + ix] /
                       static_cast<double>(image.max_value);
      const double p = negate ? v : 1.0 - v;
      const CellState state = p > occupied ? CellState::kOccupied
                              : p < free   ? CellState::kFree
                                           : CellState::kUnknown;
      grid.cells[static_cast<std::size_t>(image.height - 1 - row) * image.width + ix] = state;
    }
  }
  return grid;
}

}  // namespace shape_slam::io
