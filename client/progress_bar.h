// A one-line progress bar on stderr for uploads, progressive renders and animations. Drawn only
// when asked (the CLI asks when stderr is a terminal), so logs and pipes stay free of \r noise.
#pragma once

#include <chrono>
#include <string>
#include <string_view>

namespace caustica::client {

bool stderr_is_terminal();

class ProgressBar {
 public:
  ProgressBar(std::string label, bool enabled) : label_(std::move(label)), enabled_(enabled) {}
  ~ProgressBar();  // ends the line when anything was drawn
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Redraws at most ~20 times a second, and always when done reaches total.
  void update(double done, double total, std::string_view detail = {});

 private:
  std::string label_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace caustica::client
