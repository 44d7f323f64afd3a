#include "progress.h"

#include <unistd.h>

#include <cstdio>

namespace shape_slam::app {

ProgressBar::ProgressBar(std::size_t total, std::string label, bool enabled)
    : total_(total),
      label_(std::move(label)),
      enabled_(enabled && ::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

void ProgressBar::Update(std::size_t done) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  Draw(done);
}

void ProgressBar::Finish() {
  if (!enabled_) return;
  Draw(total_);
  std::fputc('\n', stderr);
}

void ProgressBar::Draw(std::size_t done) {
  constexpr int kWidth = 30;
  const double fraction = total_ == 0 ? 1.0 : static_cast<double>(done) / total_;
  const int filled = static_cast<int>(fraction * kWidth);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double eta = done == 0 ? 0.0 : elapsed * (total_ - done) / done;
  std::string bar(filled, '#');
  bar.append(kWidth - filled, '-');
  std::fprintf(stderr, "\r%s [%s] %3d%% %zu/%zu  %.1fs elapsed, ETA %.1fs ", label_.c_str(),
               bar.c_str(), static_cast<int>(fraction * 100), done, total_, elapsed, eta);
  std::fflush(stderr);
}

}  // namespace shape_slam::app
