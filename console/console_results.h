#pragma once
// The console's Results page: `hapticlab analyze` run on the study from the
// browser (on a thread of its own; the tables and figures of the report),
// `hapticlab export` of the samples likewise (into exports/), and the files
// served for download from one folder, never outside it. One job at a time.

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticlab::console {

class ConsoleResults {
 public:
  // `out_dir`: where the analysis writes (metrics.csv, report.html, report.md, figures/).
  ConsoleResults(std::filesystem::path db, std::filesystem::path out_dir);
  ~ConsoleResults();  // waits for a running analysis
  ConsoleResults(const ConsoleResults&) = delete;
  ConsoleResults& operator=(const ConsoleResults&) = delete;

  // Starts the analysis; throws std::invalid_argument while a job runs.
  void start(bool plots);
  // Starts a sample export into out_dir/exports (emptied first), as
  // `hapticlab export --one-file [--gzip] [--every N] [--participant P]`
  // (every started trial; `participant` empty: all). Throws
  // std::invalid_argument while a job runs.
  void start_export(const std::string& participant, std::uint64_t every, bool gzip);
  // State, message, the files there are: only those made from the study
  // the database holds now (a folder left by an earlier database of the
  // same name, re-created since, offers nothing). Reads the database.
  nlohmann::json status() const;
  // The file `name` names inside out_dir ("report.html", "figures/x.svg"),
  // or nothing when the name is not one of a plain file in it (no "..", no
  // absolute path, no link leading out). Throws std::invalid_argument when
  // the file was made from another database than the one there now.
  std::optional<std::filesystem::path> file(const std::string& name) const;

  // What tells this database's study from an earlier one at the same
  // path: its name, its creation time (ms) and its protocol's SHA-256; ""
  // when the database cannot be read.
  std::string database_identity() const;

 private:
  void run(bool plots);
  void run_export(std::string participant, std::uint64_t every, bool gzip);
  void begin(const char* job);  // caller holds mutex_
  void finish(std::string state, std::string message);
  // The identity stamped on the files of `name` ("report.html" or
  // "exports/..."), "" when none.
  std::string stamp_of(const std::string& name) const;

  const std::filesystem::path db_, out_dir_;
  mutable std::mutex mutex_;
  std::thread thread_;
  std::string job_;              // "analysis" or "export": the last one started
  // idle, running, done, incomplete (done, with damaged sample chunks left
  // out), failed
  std::string state_ = "idle";
  std::string message_;
  std::vector<std::string> exported_;  // files of the last export, relative to out_dir
};

}  // namespace hapticlab::console
