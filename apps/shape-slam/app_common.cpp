#include "app_common.h"

#include <signal.h>
#include <unistd.h>

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

LaserScan ReadScanAt(const std::string& path, long long index, bool strict) {
  const std::unique_ptr<io::LogReader> reader = OpenLogForApp(path, strict);
  long long count = 0;
  while (std::optional<LaserScan> scan = reader->Next()) {
    if (count++ == index) {
      ReportLogIssues(*reader);
      return *scan;
    }
  }
  ReportLogIssues(*reader);
  throw std::runtime_error(path + ": scan " + std::to_string(index) + " does not exist (the log has " +
                           std::to_string(count) + " laser scans, indices 0.." +
                           std::to_string(count - 1) + ")");
}

ShapeSlamParams LoadParamsForApp(const std::optional<std::string>& ini_path) {
  return ini_path ? io::LoadParamsIni(*ini_path) : ShapeSlamParams{};
}

}  // namespace shape_slam::app
