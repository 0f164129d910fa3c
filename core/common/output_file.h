#pragma once
// Output files that are either complete or absent.
//
// A command that fails half-way (disk full, file size limit, an exception in
// the computation) must not leave a file that looks like a result: a 0-byte
// metrics.csv or a truncated replay reads as data. AtomicOutputFile writes to
// a temporary file in the target's directory ("<name>.<pid>.tmp") and renames
// it over the target only after every byte was written, flushed to disk and
// the file closed without error. Rename within one directory is atomic, so a
// reader sees the old file or the new one, never a mix.
//
// A target that exists and is not a regular file (/dev/stdout, /dev/null, a
// FIFO) cannot be replaced by a rename; it is written directly.
//
// Every error is an OutputFileError naming the target path and the cause
// from the system (strerror), e.g.
//   "out/metrics.csv: cannot write: No space left on device".

#include <filesystem>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string_view>

namespace hapticlab {

class OutputFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class AtomicOutputFile {
 public:
  // Creates the temporary file; throws OutputFileError if it cannot.
  explicit AtomicOutputFile(std::filesystem::path path);
  // Not committed: the temporary file is removed. Never throws.
  ~AtomicOutputFile();
  // Owns a file descriptor and a stream pointing into itself.
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  // Write here. A failed write sets the stream's badbit; commit() reports it.
  std::ostream& stream();
  // Flush, fsync, close, rename. Throws OutputFileError naming the path and
  // the first error met (the temporary file is then removed).
  void commit();
  // Throws what commit() would if a write has failed already; for writers
  // that stop at the first failed line with a message of their own.
  void check();

  const std::filesystem::path& path() const noexcept { return path_; }
  // Where the bytes go until commit() (the path itself for a device or FIFO).
  const std::filesystem::path& temp_path() const noexcept { return temp_; }

 private:
  class Buffer;
  [[noreturn]] void fail(std::string_view action, int error);
  void discard() noexcept;

  std::filesystem::path path_;
  std::filesystem::path temp_;
  bool direct_ = false;  // writing straight into a device or FIFO
  bool committed_ = false;
  int fd_ = -1;
  std::unique_ptr<Buffer> buffer_;
  std::unique_ptr<std::ostream> stream_;
};

// The whole of `text` as `path`, through an AtomicOutputFile.
void write_file_atomically(const std::filesystem::path& path, std::string_view text);

// Throws OutputFileError when `output` names the same file as `input` (also
// through a link or another spelling of the path): writing the output would
// destroy the input. `option` names the output option in the message.
void refuse_output_over_input(const std::filesystem::path& input, const std::filesystem::path& output,
                              std::string_view input_option, std::string_view output_option);

}  // namespace hapticlab
