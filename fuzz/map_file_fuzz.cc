// Fuzz target of the polyline map file reader (map_file.h): the input is the text of a
// map.polylines file, parsed as LoadMapFile does after reading the file. The reader must return
// a map or throw MapFileError; any other exception, a crash, a sanitizer report, a time-out or
// running out of memory is a finding. A map it accepts must survive FormatMapFile ->
// ParseMapFile exactly (the header promises an exact save/load round trip).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "shape_slam_io/map_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using shape_slam::fuzz::Check;
  namespace io = shape_slam::io;
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::string formatted;
  std::size_t polylines = 0;
  try {
    const shape_slam::PolylineMap map = io::ParseMapFile(text, "fuzz.polylines");
    formatted = io::FormatMapFile(map);
    polylines = map.NumPolylines();
  } catch (const io::MapFileError&) {
    return 0;
  }
  try {
    const shape_slam::PolylineMap again = io::ParseMapFile(formatted, "formatted.polylines");
    Check(again.NumPolylines() == polylines, "the round trip keeps every polyline");
    Check(io::FormatMapFile(again) == formatted, "the round trip is exact");
  } catch (const io::MapFileError&) {
    Check(false, "FormatMapFile of a loaded map parses back");
  }
  return 0;
}
