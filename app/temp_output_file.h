#pragma once
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "core/io/trajectory_csv.h"

namespace hapticlab::app {

// The output is written next to its final name and renamed only once every
// row succeeded, so a failed replay never leaves a file that looks complete.
class TempOutputFile {
 public:
  explicit TempOutputFile(std::filesystem::path final_path)
      : final_(std::move(final_path)), temp_(final_.string() + ".tmp") {
    stream_.open(temp_, std::ios::binary | std::ios::trunc);
    if (!stream_) throw TrajectoryCsvError(temp_.string() + ": cannot open for writing");
  }
  TempOutputFile(const TempOutputFile&) = delete;
  TempOutputFile& operator=(const TempOutputFile&) = delete;
  ~TempOutputFile() {
    if (committed_) return;
    stream_.close();
    std::error_code ignored;  // best effort: the destructor must not throw
    std::filesystem::remove(temp_, ignored);
  }

  std::ostream& stream() { return stream_; }

  void commit() {
    stream_.close();
    if (!stream_) throw TrajectoryCsvError(temp_.string() + ": write failed");
    std::filesystem::rename(temp_, final_);
    committed_ = true;
  }

 private:
  std::filesystem::path final_;
  std::filesystem::path temp_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace hapticlab::app
