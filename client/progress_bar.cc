// Drawing the stderr progress bar (see progress_bar.h).
#include "client/progress_bar.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace caustica::client {
namespace {

constexpr int kBarWidth = 30;
constexpr auto kRedrawInterval = std::chrono::milliseconds(50);

}  // namespace

bool stderr_is_terminal() { return isatty(STDERR_FILENO) != 0; }

void ProgressBar::update(double done, double total, std::string_view detail) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const bool finished = total > 0 && done >= total;
  if (drawn_ && !finished && now - last_draw_ < kRedrawInterval) return;
  last_draw_ = now;
  drawn_ = true;
  const double fraction = total > 0 ? std::clamp(done / total, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(fraction * kBarWidth + 0.5);
  const std::string bar = std::string(filled, '#') + std::string(kBarWidth - filled, '.');
  // \033[K clears what a longer earlier line left behind.
  std::fprintf(stderr, "\r%s [%s] %3d%% %.*s\033[K", label_.c_str(), bar.c_str(),
               static_cast<int>(fraction * 100), static_cast<int>(detail.size()), detail.data());
  std::fflush(stderr);
}

ProgressBar::~ProgressBar() {
  if (drawn_) std::fputc('\n', stderr);
}

}  // namespace caustica::client
