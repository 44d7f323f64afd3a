#include "shape_slam_mrpt/options.h"

#include <mrpt/config/CConfigFileBase.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <ostream>
#include <set>
#include <stdexcept>

#include "option_fields.h"

namespace shape_slam {
namespace {

void Positive(double value, const char* name) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(name) + " must be > 0");
  }
}

void Fraction(double value, const char* name) {
  if (!(value >= 0.0 && value <= 1.0)) {
    throw std::invalid_argument(std::string(name) + " must be in [0, 1]");
  }
}

std::string Trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1);
}

// MRPT strips "//" comments itself; ';' and '#' comments after whitespace are dropped here.
std::string StripComment(const std::string& value) {
  for (std::size_t i = 1; i < value.size(); ++i) {
    if ((value[i] == ';' || value[i] == '#') && (value[i - 1] == ' ' || value[i - 1] == '\t')) {
      return Trim(value.substr(0, i));
    }
  }
  return Trim(value);
}

// Not "[section] key": MRPT's exception wrapper takes a leading bracket for a source location.
std::string Where(const std::string& section, const std::string& key) {
  return "ini section '" + section + "', key '" + key + "'";
}

// Parses the text of one value for `field`; throws naming section and key.
double ParseValue(const OptionField& field, const std::string& text, const std::string& where) {
  if (std::holds_alternative<bool*>(field.target)) {
    return ParseBool(text, where) ? 1.0 : 0.0;
  }
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw std::invalid_argument(where + ": '" + text + "' is not a finite number");
  }
  return value;
}

// MRPT's own keys of a creation section (TMapGenericParams) and map_file (read by
// LoadMapFileOption), accepted beside ours.
const std::set<std::string>& GenericKeys() {
  static const std::set<std::string> keys = {"enablesaveas3dobject", "enableobservationlikelihood",
                                             "enableobservationinsertion", "map_file"};
  return keys;
}

void CheckUnknownKeys(const mrpt::config::CConfigFileBase& source, const std::string& section,
                      OptionSection which, const std::vector<OptionField>& fields) {
  std::set<std::string> known;
  for (const OptionField& f : fields) {
    if (f.section == which) known.insert(Lower(f.key));
  }
  if (which == OptionSection::kCreation) known.insert(GenericKeys().begin(), GenericKeys().end());
  std::vector<std::string> keys;
  source.getAllKeys(section, keys);
  for (const std::string& key : keys) {
    if (known.count(Lower(key)) > 0) continue;
    std::string list;
    for (const OptionField& f : fields) {
      if (f.section == which) list += std::string(list.empty() ? "" : ", ") + f.key;
    }
    throw std::invalid_argument(Where(section, key) + ": unknown key (known keys: " + list + ")");
  }
}

}  // namespace

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool ParseBool(const std::string& text, const std::string& where) {
  const std::string v = Lower(text);
  if (v == "1" || v == "true" || v == "yes" || v == "on") return true;
  if (v == "0" || v == "false" || v == "no" || v == "off") return false;
  throw std::invalid_argument(where + ": '" + text + "' is not a boolean (true/false, 1/0)");
}

const char* SectionSuffix(OptionSection section) {
  switch (section) {
    case OptionSection::kCreation:
      return "_creationOpts";
    case OptionSection::kInsertion:
      return "_insertOpts";
    case OptionSection::kLikelihood:
      return "_likelihoodOpts";
  }
  return "";
}

std::vector<OptionField> OptionFields(PolylineMapOptions& o) {
  using S = OptionSection;
  InsertionOptions& in = o.insertion;
  MapUpdateParams& mu = in.map_update;
  return {
      {S::kCreation, "index_cell_size_m", &o.creation.index_cell_size_m},
      {S::kCreation, "sample_spacing_m", &o.creation.sample_spacing_m},
      {S::kCreation, "keep_scan_points", &o.creation.keep_scan_points},
      {S::kCreation, "scan_points_spacing_m", &o.creation.scan_points_spacing_m},
      {S::kInsertion, "max_gap_m", &in.shapes.extraction.max_gap_m},
      {S::kInsertion, "gap_beam_spacing_factor", &in.shapes.extraction.gap_beam_spacing_factor},
      {S::kInsertion, "min_range_m", &in.shapes.extraction.min_range_m},
      {S::kInsertion, "min_points", &in.shapes.extraction.min_points},
      {S::kInsertion, "alignment_dce_threshold_m", &in.shapes.alignment_dce_threshold_m},
      {S::kInsertion, "alignment_max_deviation_m", &in.shapes.alignment_max_deviation_m},
      {S::kInsertion, "visibility_max_range_m", &in.visibility.max_range_m},
      {S::kInsertion, "visibility_angular_resolution_rad", &in.visibility.angular_resolution_rad},
      {S::kInsertion, "visibility_min_piece_length_m", &in.visibility.min_piece_length_m},
      {S::kInsertion, "visibility_depth_tolerance_m", &in.visibility.depth_tolerance_m},
      {S::kInsertion, "visibility_fov_margin_rad", &in.visibility_fov_margin_rad},
      {S::kInsertion, "dce_threshold_m", &mu.dce_threshold_m},
      {S::kInsertion, "max_deviation_m", &mu.max_deviation_m},
      {S::kInsertion, "merge_sample_spacing_m", &mu.merge_sample_spacing_m},
      {S::kInsertion, "min_incidence_rad", &mu.min_incidence_rad},
      {S::kInsertion, "max_support", &mu.max_support},
      {S::kInsertion, "merge_max_misfit_m", &mu.merge_max_misfit_m},
      {S::kInsertion, "merge_max_angle_rad", &mu.merge_max_angle_rad},
      {S::kInsertion, "merge_min_overlap_m", &mu.merge_min_overlap_m},
      {S::kInsertion, "merge_min_overlap_fraction", &mu.merge_min_overlap_fraction},
      {S::kInsertion, "untrusted_clearance_m", &mu.untrusted_clearance_m},
      {S::kInsertion, "untrusted_near_fraction", &mu.untrusted_near_fraction},
      {S::kInsertion, "explained_distance_m", &mu.explained_distance_m},
      {S::kInsertion, "explained_fraction", &mu.explained_fraction},
      {S::kInsertion, "min_new_length_m", &mu.min_new_length_m},
      {S::kInsertion, "contradiction_margin_m", &mu.contradiction_margin_m},
      {S::kInsertion, "drop_max_observations", &mu.drop_max_observations},
      {S::kInsertion, "drop_min_contradictions", &mu.drop_min_contradictions},
      {S::kInsertion, "check_sample_spacing_m", &mu.check_sample_spacing_m},
      {S::kInsertion, "merge_check_spacing_m", &mu.merge_check_spacing_m},
      {S::kLikelihood, "sigma_m", &o.likelihood.sigma_m},
      {S::kLikelihood, "max_corr_distance_m", &o.likelihood.max_corr_distance_m},
      {S::kLikelihood, "z_hit", &o.likelihood.z_hit},
      {S::kLikelihood, "z_random", &o.likelihood.z_random},
      {S::kLikelihood, "max_range_m", &o.likelihood.max_range_m},
      {S::kLikelihood, "decimation", &o.likelihood.decimation},
  };
}

double FieldValue(const OptionField& field) {
  if (const auto* d = std::get_if<double*>(&field.target)) return **d;
  if (const auto* i = std::get_if<int*>(&field.target)) return **i;
  return *std::get<bool*>(field.target) ? 1.0 : 0.0;
}

void SetFieldValue(const OptionField& field, double value) {
  if (const auto* d = std::get_if<double*>(&field.target)) {
    **d = value;
  } else if (const auto* i = std::get_if<int*>(&field.target)) {
    if (value != std::floor(value) || std::abs(value) > 1e9) {
      throw std::invalid_argument(std::string(field.key) + " must be an integer");
    }
    **i = static_cast<int>(value);
  } else {
    if (value != 0.0 && value != 1.0) {
      throw std::invalid_argument(std::string(field.key) + " must be a boolean");
    }
    *std::get<bool*>(field.target) = value != 0.0;
  }
}

void CreationOptions::Validate() const {
  Positive(index_cell_size_m, "CreationOptions::index_cell_size_m");
  Positive(sample_spacing_m, "CreationOptions::sample_spacing_m");
  if (!(scan_points_spacing_m >= 0.0) || !std::isfinite(scan_points_spacing_m)) {
    throw std::invalid_argument("CreationOptions::scan_points_spacing_m must be >= 0");
  }
}

void LikelihoodOptions::Validate() const {
  Positive(sigma_m, "LikelihoodOptions::sigma_m");
  Positive(max_corr_distance_m, "LikelihoodOptions::max_corr_distance_m");
  Positive(max_range_m, "LikelihoodOptions::max_range_m");
  Fraction(z_hit, "LikelihoodOptions::z_hit");
  Fraction(z_random, "LikelihoodOptions::z_random");
  if (!(z_hit + z_random > 0.0)) {
    throw std::invalid_argument("LikelihoodOptions: z_hit + z_random must be > 0");
  }
  if (decimation < 1) throw std::invalid_argument("LikelihoodOptions::decimation must be >= 1");
}

void PolylineMapOptions::Validate() const {
  creation.Validate();
  insertion.Validate();
  likelihood.Validate();
}

PolylineMapOptions LoadPolylineMapOptions(const mrpt::config::CConfigFileBase& source,
                                          const std::string& prefix,
                                          const PolylineMapOptions& defaults) {
  PolylineMapOptions options = defaults;
  const std::vector<OptionField> fields = OptionFields(options);
  for (const OptionSection which :
       {OptionSection::kCreation, OptionSection::kInsertion, OptionSection::kLikelihood}) {
    const std::string section = prefix + SectionSuffix(which);
    if (!source.sectionExists(section)) continue;
    CheckUnknownKeys(source, section, which, fields);
    for (const OptionField& field : fields) {
      if (field.section != which) continue;
      const std::string text = StripComment(source.read_string(section, field.key, ""));
      if (text.empty()) continue;
      const std::string where = Where(section, field.key);
      try {
        SetFieldValue(field, ParseValue(field, text, where));
      } catch (const std::invalid_argument& e) {
        const std::string message = e.what();
        throw std::invalid_argument(message.rfind(where, 0) == 0 ? message
                                                                 : where + ": " + message);
      }
    }
  }
  try {
    options.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("ini sections '" + prefix + "_*Opts': " + e.what());
  }
  return options;
}

std::string LoadMapFileOption(const mrpt::config::CConfigFileBase& source,
                              const std::string& prefix) {
  const std::string section = prefix + SectionSuffix(OptionSection::kCreation);
  if (!source.sectionExists(section)) return "";
  return StripComment(source.read_string(section, "map_file", ""));
}

void DumpPolylineMapOptions(const PolylineMapOptions& options, const std::string& prefix,
                            std::ostream& out) {
  PolylineMapOptions copy = options;
  const std::vector<OptionField> fields = OptionFields(copy);
  for (const OptionSection which :
       {OptionSection::kCreation, OptionSection::kInsertion, OptionSection::kLikelihood}) {
    out << "[" << prefix << SectionSuffix(which) << "]\n";
    for (const OptionField& field : fields) {
      if (field.section == which) out << field.key << " = " << FieldValue(field) << "\n";
    }
  }
}

bool operator==(const PolylineMapOptions& a, const PolylineMapOptions& b) {
  PolylineMapOptions ca = a, cb = b;
  const std::vector<OptionField> fa = OptionFields(ca), fb = OptionFields(cb);
  for (std::size_t i = 0; i < fa.size(); ++i) {
    if (FieldValue(fa[i]) != FieldValue(fb[i])) return false;
  }
  return true;
}

}  // namespace shape_slam
