#include "cli.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace shape_slam::app {

double ParseDouble(const std::string& text, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE ||
      !std::isfinite(value)) {
    throw UsageError(what + ": '" + text + "' is not a finite number");
  }
  return value;
}

ArgParser::ArgParser(std::string command, std::string summary)
    : command_(std::move(command)), summary_(std::move(summary)) {}

ArgParser& ArgParser::Positional(const std::string& name, const std::string& help, bool required) {
  specs_.push_back({name, help, "", {}, true, required});
  return *this;
}

ArgParser& ArgParser::Flag(const std::string& name, const std::string& help) {
  specs_.push_back({name, help, "", {}, false, false});
  return *this;
}

ArgParser& ArgParser::Option(const std::string& name, const std::vector<std::string>& metavars,
                             const std::string& help, const std::string& default_text) {
  specs_.push_back({name, help, default_text, metavars, false, false});
  return *this;
}

ArgParser& ArgParser::Epilog(const std::string& text) {
  epilog_ = text;
  return *this;
}

const ArgParser::Spec* ArgParser::Find(const std::string& name) const {
  for (const Spec& spec : specs_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

bool ArgParser::Parse(const std::vector<std::string>& args) {
  std::vector<std::string> positionals;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "-h" || arg == "--help") return false;
    if (arg.size() > 1 && arg[0] == '-' && !(std::isdigit(arg[1]) || arg[1] == '.')) {
      const Spec* spec = Find(arg);
      if (spec == nullptr || spec->positional) {
        throw UsageError("unknown option '" + arg + "'");
      }
      if (values_.count(arg)) throw UsageError("option '" + arg + "' given twice");
      std::vector<std::string> values;
      for (std::size_t k = 0; k < spec->metavars.size(); ++k) {
        if (++i >= args.size()) {
          throw UsageError("option '" + arg + "' needs " + std::to_string(spec->metavars.size()) +
                           " value(s)");
        }
        values.push_back(args[i]);
      }
      values_[arg] = values;
    } else {
      positionals.push_back(arg);
    }
  }
  std::size_t next = 0;
  for (const Spec& spec : specs_) {
    if (!spec.positional) continue;
    if (next < positionals.size()) {
      values_[spec.name] = {positionals[next++]};
    } else if (spec.required) {
      throw UsageError("missing argument " + spec.name);
    }
  }
  if (next < positionals.size()) {
    throw UsageError("unexpected argument '" + positionals[next] + "'");
  }
  return true;
}

bool ArgParser::Has(const std::string& name) const { return values_.count(name) > 0; }

std::string ArgParser::Get(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end() || it->second.empty()) throw UsageError("missing " + name);
  return it->second.front();
}

std::optional<std::string> ArgParser::GetOptional(const std::string& name) const {
  if (!Has(name)) return std::nullopt;
  return Get(name);
}

std::vector<double> ArgParser::GetDoubles(const std::string& name) const {
  std::vector<double> out;
  const auto it = values_.find(name);
  if (it == values_.end()) return out;
  for (const std::string& text : it->second) out.push_back(ParseDouble(text, name));
  return out;
}

double ArgParser::GetDouble(const std::string& name, double default_value) const {
  return Has(name) ? ParseDouble(Get(name), name) : default_value;
}

long long ArgParser::GetIndex(const std::string& name) const {
  const std::string text = Get(name);
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || value < 0) {
    throw UsageError(name + ": '" + text + "' is not a non-negative integer");
  }
  return value;
}

std::string ArgParser::Help() const {
  std::ostringstream out;
  out << "Usage: shape-slam " << command_;
  for (const Spec& spec : specs_) {
    if (spec.positional) out << (spec.required ? " " : " [") << spec.name << (spec.required ? "" : "]");
  }
  out << " [options]\n\n" << summary_ << "\n\n";
  auto line = [&](const std::string& left, const Spec& spec) {
    out << "  " << left;
    if (left.size() < 26) out << std::string(26 - left.size(), ' ');
    else out << "\n  " << std::string(26, ' ');
    out << spec.help;
    if (!spec.default_text.empty()) out << " (default: " << spec.default_text << ")";
    out << "\n";
  };
  out << "Arguments:\n";
  for (const Spec& spec : specs_) {
    if (spec.positional) line(spec.name, spec);
  }
  out << "\nOptions:\n";
  for (const Spec& spec : specs_) {
    if (spec.positional) continue;
    std::string left = spec.name;
    for (const std::string& metavar : spec.metavars) left += " " + metavar;
    line(left, spec);
  }
  out << "  -h, --help                show this help\n";
  if (!epilog_.empty()) out << "\n" << epilog_ << "\n";
  return out.str();
}

}  // namespace shape_slam::app
