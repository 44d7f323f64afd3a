#include "app_common.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <stdexcept>

#include "shape_slam_io/params_ini.h"

namespace shape_slam::app {
namespace {

char g_fatal_context[512] = "running";

void Write(const char* text) {
  const ssize_t ignored = ::write(STDERR_FILENO, text, std::strlen(text));
  (void)ignored;
}

// Async-signal-safe: write(2) and _exit(2) only.
extern "C" void OnFatalSignal(int signal_number) {
  Write("shape-slam: error: fatal signal (");
  Write(signal_number == SIGSEGV ? "SIGSEGV"
        : signal_number == SIGBUS ? "SIGBUS"
        : signal_number == SIGFPE ? "SIGFPE"
                                  : "SIGILL");
  Write(") while ");
  Write(g_fatal_context);
  Write(".\nThe input is probably corrupt in a way its decoder did not survive; if it is not, "
        "please report this with the input.\n");
  ::_exit(1);
}

}  // namespace

void InstallFatalSignalHandlers() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_UNDEFINED__)
  return;
#else
  static char alternate_stack[1 << 16];  // so that a stack overflow can be reported too
  stack_t stack{};
  stack.ss_sp = alternate_stack;
  stack.ss_size = sizeof alternate_stack;
  ::sigaltstack(&stack, nullptr);
  struct sigaction action {};
  action.sa_handler = OnFatalSignal;
  action.sa_flags = SA_ONSTACK | SA_RESETHAND;
  sigemptyset(&action.sa_mask);
  for (const int signal_number : {SIGSEGV, SIGBUS, SIGFPE, SIGILL}) {
    ::sigaction(signal_number, &action, nullptr);
  }
#endif
}

void SetFatalContext(const std::string& context) {
  const std::size_t n = std::min(context.size(), sizeof g_fatal_context - 1);
  std::memcpy(g_fatal_context, context.data(), n);
  g_fatal_context[n] = '\0';
}

std::unique_ptr<io::LogReader> OpenLogForApp(const std::string& path, bool strict) {
  SetFatalContext("reading the log " + path.substr(0, 400));
  io::LogReaderOptions options;
  options.strict = strict;
  return io::OpenLog(path, options);
}

void ReportLogIssues(const io::LogReader& reader) {
  const io::LogReaderStats& stats = reader.Stats();
  constexpr std::size_t kMaxLines = 10;
  for (std::size_t i = 0; i < stats.issues.size() && i < kMaxLines; ++i) {
    std::cerr << "warning: " << stats.issues[i].where << ": " << stats.issues[i].message << "\n";
  }
  if (stats.skipped_records > 0) {
    std::cerr << "warning: " << reader.Path() << ": skipped " << stats.skipped_records
              << " malformed record(s); use --strict to stop at the first one\n";
  }
  if (stats.invalid_ranges > 0) {
    std::cerr << "warning: " << reader.Path() << ": " << stats.invalid_ranges
              << " NaN/inf/negative range reading(s) treated as no reading\n";
  }
}

std::vector<LaserScan> ReadScansAt(const std::string& path, const std::vector<long long>& indices,
                                   bool strict) {
  const std::unique_ptr<io::LogReader> reader = OpenLogForApp(path, strict);
  const long long last = indices.empty() ? -1 : *std::max_element(indices.begin(), indices.end());
  std::vector<std::optional<LaserScan>> found(indices.size());
  long long count = 0;
  while (count <= last) {
    std::optional<LaserScan> scan = reader->Next();
    if (!scan) break;
    for (std::size_t k = 0; k < indices.size(); ++k) {
      if (indices[k] == count) found[k] = *scan;
    }
    ++count;
  }
  ReportLogIssues(*reader);
  std::vector<LaserScan> scans;
  for (std::size_t k = 0; k < indices.size(); ++k) {
    if (!found[k]) {
      while (reader->Next()) ++count;  // the whole count, for the message
      throw std::runtime_error(path + ": scan " + std::to_string(indices[k]) +
                               " does not exist (the log has " + std::to_string(count) +
                               " laser scans, indices 0.." + std::to_string(count - 1) + ")");
    }
    scans.push_back(std::move(*found[k]));
  }
  return scans;
}

LaserScan ReadScanAt(const std::string& path, long long index, bool strict) {
  return ReadScansAt(path, {index}, strict).front();
}

ShapeSlamParams LoadParamsForApp(const std::optional<std::string>& ini_path) {
  return LoadLocalizerParamsForApp(ini_path).stages;
}

LocalizerParams LoadLocalizerParamsForApp(const std::optional<std::string>& ini_path) {
  return ini_path ? io::LoadLocalizerParamsIni(*ini_path) : LocalizerParams{};
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double position = q * (values.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(position));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (position - lo) * (values[hi] - values[lo]);
}

}  // namespace shape_slam::app
