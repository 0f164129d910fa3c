#pragma once
// The console's Results page: `hapticlab analyze` run on the study from the
// browser (on a thread of its own; the tables and figures of the report), and
// its files served for download from one folder, never outside it.

#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

namespace hapticlab::console {

class ConsoleResults {
 public:
  // `out_dir`: where the analysis writes (metrics.csv, report.html, report.md, figures/).
  ConsoleResults(std::filesystem::path db, std::filesystem::path out_dir);
  ~ConsoleResults();  // waits for a running analysis
  ConsoleResults(const ConsoleResults&) = delete;
  ConsoleResults& operator=(const ConsoleResults&) = delete;

  // Starts the analysis; throws std::invalid_argument while one runs.
  void start(bool plots);
  nlohmann::json status() const;  // state, message, the files there are
  // The file `name` names inside out_dir ("report.html", "figures/x.svg"),
  // or nothing when the name is not one of a plain file in it (no "..", no
  // absolute path, no link leading out).
  std::optional<std::filesystem::path> file(const std::string& name) const;

 private:
  void run(bool plots);

  const std::filesystem::path db_, out_dir_;
  mutable std::mutex mutex_;
  std::thread thread_;
  std::string state_ = "idle";  // idle, running, done, failed
  std::string message_;
};

}  // namespace hapticlab::console
