#include "app/cli/progress_line.h"

#include <algorithm>
#include <cmath>

#include <unistd.h>

namespace hapticlab::app {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) return "--:--";
  const long total = std::lround(seconds);
  char text[32];
  if (total >= 3600) {
    std::snprintf(text, sizeof text, "%ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  } else {
    std::snprintf(text, sizeof text, "%ld:%02ld", total / 60, total % 60);
  }
  return text;
}

std::string format_bar(double fraction, int width) {
  const double f = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::floor(f * width));
  std::string bar = "[" + std::string(static_cast<std::size_t>(filled), '#') +
                    std::string(static_cast<std::size_t>(width - filled), '.') + "]";
  char pct[8];
  std::snprintf(pct, sizeof pct, " %3d%%", static_cast<int>(std::floor(f * 100.0)));
  return bar + pct;
}

ProgressLine::ProgressLine(std::FILE* out) : out_(out), tty_(isatty(fileno(out)) != 0) {}

ProgressLine::~ProgressLine() { finish(); }

void ProgressLine::update(double fraction, const std::string& label, double elapsed_s,
                          std::optional<double> eta_s) {
  std::string line = format_bar(fraction) + "  " + label + "  elapsed " + format_duration(elapsed_s) +
                     "  left " + (eta_s ? format_duration(*eta_s) : std::string("--:--"));
  if (!tty_) {
    // A log gets one line per tenth of the way, not one per update.
    const int decile = std::isfinite(fraction) ? static_cast<int>(std::floor(std::clamp(fraction, 0.0, 1.0) * 10.0)) : 0;
    if (decile > last_decile_) {
      last_decile_ = decile;
      std::fprintf(out_, "%s\n", line.c_str());
      std::fflush(out_);
    }
    return;
  }
  const std::size_t width = line.size();
  if (width < last_width_) line += std::string(last_width_ - width, ' ');  // erase the old tail
  std::fprintf(out_, "\r%s", line.c_str());
  std::fflush(out_);
  last_width_ = width;
  drawn_ = true;
}

void ProgressLine::print(const std::string& text) {
  if (tty_ && drawn_) std::fprintf(out_, "\r%s\r", std::string(last_width_, ' ').c_str());
  std::fprintf(out_, "%s\n", text.c_str());
  std::fflush(out_);
  drawn_ = false;
  last_width_ = 0;
}

void ProgressLine::finish() {
  if (tty_ && drawn_) {
    std::fputc('\n', out_);
    std::fflush(out_);
  }
  drawn_ = false;
  last_width_ = 0;
}

}  // namespace hapticlab::app
