// Private: the table binding every option of PolylineMapOptions to its ini section and key, used
// by the ini loader, the text dump, equality and serialization.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "shape_slam_mrpt/options.h"

namespace shape_slam {

enum class OptionSection { kCreation, kInsertion, kLikelihood };

/// "_creationOpts", "_insertOpts", "_likelihoodOpts".
const char* SectionSuffix(OptionSection section);

struct OptionField {
  OptionSection section;
  const char* key;
  std::variant<double*, int*, bool*> target;
};

/// Lower-case copy (ASCII), for case-insensitive ini keys.
std::string Lower(std::string s);
/// An ini boolean (1/0, true/false, yes/no, on/off, any case); throws std::invalid_argument
/// naming `where` otherwise.
bool ParseBool(const std::string& text, const std::string& where);

/// Every option, bound to `options`' fields.
std::vector<OptionField> OptionFields(PolylineMapOptions& options);

/// The value of a field as a double (ints and bools converted exactly).
double FieldValue(const OptionField& field);
/// Sets a field from a double; throws std::invalid_argument naming the key when the value does
/// not fit the field's type (a fraction for an int, not 0/1 for a bool).
void SetFieldValue(const OptionField& field, double value);

}  // namespace shape_slam
