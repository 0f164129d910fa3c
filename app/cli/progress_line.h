#pragma once
// One status line on the operator's terminal: a bar, a label, elapsed time
// and the estimated time left. On a terminal it redraws in place (\r); into
// a file or pipe it prints the bar once per tenth of progress, so logs stay
// readable.

#include <cstdio>
#include <optional>
#include <string>

namespace hapticlab::app {

// "1:05", "12:00:07": minutes:seconds, hours when needed; "--:--" for a
// negative or non-finite time.
std::string format_duration(double seconds);

// "[#######.............]  35%" for fraction in [0, 1] (clamped).
std::string format_bar(double fraction, int width = 24);

class ProgressLine {
 public:
  explicit ProgressLine(std::FILE* out = stdout);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // Redraws the line (terminal), or prints it when `fraction` enters a new
  // tenth (file).
  void update(double fraction, const std::string& label, double elapsed_s, std::optional<double> eta_s);
  // Prints `text` as a line of its own, above the bar on a terminal.
  void print(const std::string& text);
  // Ends the bar's line (a terminal otherwise keeps it under the prompt).
  void finish();

 private:
  std::FILE* out_;
  bool tty_;
  bool drawn_ = false;
  std::size_t last_width_ = 0;
  int last_decile_ = 0;
};

}  // namespace hapticlab::app
