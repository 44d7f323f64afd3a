// The mapper's and the localizer's parameters as an ini file: one section per stage, every key
// documented; [localizer] holds LocalizerParams' own fields (its stages are the mapper's
// sections). The parser is strict: an unknown section or key, a duplicate, or a value that does
// not parse or fails validation is an error naming the file, line and key -- a typo must never
// be silently ignored. The mapper's readers check [localizer] too, so one file serves both.
// config/default.ini is FormatParamsIni(LocalizerParams{}).
#pragma once

#include <stdexcept>
#include <string>

#include "shape_slam/localizer.h"
#include "shape_slam/pipeline.h"

namespace shape_slam::io {

/// An ini file that cannot be used; what() names the file, line and key.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses ini text over `defaults`; keys not given keep their default. `name` is used in
/// messages. Throws ConfigError.
ShapeSlamParams ParseParamsIni(const std::string& text, const std::string& name,
                               const ShapeSlamParams& defaults = {});

/// Reads and parses an ini file. Throws ConfigError (also for a missing or unreadable file).
ShapeSlamParams LoadParamsIni(const std::string& path);

/// The same for the localizer: every section, [localizer] included. Throws ConfigError.
LocalizerParams ParseLocalizerParamsIni(const std::string& text, const std::string& name,
                                        const LocalizerParams& defaults = {});
LocalizerParams LoadLocalizerParamsIni(const std::string& path);

/// The ini text of `params`, with a comment (meaning and unit) above every key; [localizer] has
/// the localizer's defaults.
std::string FormatParamsIni(const ShapeSlamParams& params);
/// The ini text of every key, [localizer] from `params`.
std::string FormatParamsIni(const LocalizerParams& params);

}  // namespace shape_slam::io
