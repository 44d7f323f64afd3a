// Fuzz target of the ini parameter parser (params_ini.h): the input is the text of an ini file,
// parsed over the defaults as LoadParamsIni does after reading the file. The parser must return
// valid parameters or throw ConfigError; any other exception, a crash or a sanitizer report is
// a finding. Parameters it accepts must survive FormatParamsIni -> ParseParamsIni unchanged
// (config/default.ini is written that way and read back by the app).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "shape_slam_io/params_ini.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using shape_slam::fuzz::Check;
  namespace io = shape_slam::io;
  const std::string text(reinterpret_cast<const char*>(data), size);
  shape_slam::ShapeSlamParams params;
  try {
    params = io::ParseParamsIni(text, "fuzz.ini");
  } catch (const io::ConfigError&) {
    return 0;
  }
  params.Validate();  // ParseParamsIni returns validated parameters: must not throw
  const std::string formatted = io::FormatParamsIni(params);
  shape_slam::ShapeSlamParams again;
  try {
    again = io::ParseParamsIni(formatted, "formatted.ini");
  } catch (const io::ConfigError&) {
    Check(false, "FormatParamsIni of accepted parameters parses back");
  }
  Check(io::FormatParamsIni(again) == formatted, "the ini round trip keeps every value");
  return 0;
}
