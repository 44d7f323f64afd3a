// Command-line parsing for the shape-slam tool: declared options, generated --help, strict
// validation (unknown options, missing or malformed values are usage errors, exit code 2).
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace shape_slam::app {

/// A command line that does not parse; the tool prints it with a hint and exits with 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ArgParser {
 public:
  ArgParser(std::string command, std::string summary);

  /// A positional argument, in declaration order. Optional ones must come last.
  ArgParser& Positional(const std::string& name, const std::string& help, bool required = true);
  /// A switch without value, e.g. --json.
  ArgParser& Flag(const std::string& name, const std::string& help);
  /// An option taking `metavars.size()` values, e.g. --guess X Y THETA.
  ArgParser& Option(const std::string& name, const std::vector<std::string>& metavars,
                    const std::string& help, const std::string& default_text = "");
  /// Free text appended to --help (examples, notes).
  ArgParser& Epilog(const std::string& text);

  /// Parses the arguments after the command name. Returns false when --help was asked for (the
  /// caller prints Help() and exits 0). Throws UsageError.
  bool Parse(const std::vector<std::string>& args);

  bool Has(const std::string& name) const;
  std::string Get(const std::string& name) const;
  std::optional<std::string> GetOptional(const std::string& name) const;
  /// Values of an option, parsed as finite doubles (UsageError naming the option otherwise).
  std::vector<double> GetDoubles(const std::string& name) const;
  double GetDouble(const std::string& name, double default_value) const;
  /// A non-negative integer value (UsageError otherwise).
  long long GetIndex(const std::string& name) const;

  std::string Help() const;
  const std::string& Command() const { return command_; }

 private:
  struct Spec {
    std::string name, help, default_text;
    std::vector<std::string> metavars;
    bool positional = false, required = false;
  };
  const Spec* Find(const std::string& name) const;

  std::string command_, summary_, epilog_;
  std::vector<Spec> specs_;
  std::map<std::string, std::vector<std::string>> values_;
};

/// Parses a finite double; UsageError naming `what` otherwise.
double ParseDouble(const std::string& text, const std::string& what);

}  // namespace shape_slam::app
