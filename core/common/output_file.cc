#include "core/common/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <streambuf>
#include <string>
#include <system_error>

namespace hapticlab {

// A stream buffer straight over the file descriptor, because std::ofstream
// forgets errno: "write failed" alone does not tell a full disk from a file
// size limit or a removed USB stick. The first error is kept for commit().
class AtomicOutputFile::Buffer : public std::streambuf {
 public:
  explicit Buffer(int fd) : fd_(fd) { setp(data_, data_ + sizeof data_); }
  int error() const noexcept { return error_; }

 protected:
  int_type overflow(int_type ch) override {
    if (!drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  int sync() override { return drain() ? 0 : -1; }

 private:
  bool drain() {
    if (error_ != 0) return false;
    const char* p = pbase();
    while (p < pptr()) {
      const ssize_t n = ::write(fd_, p, static_cast<std::size_t>(pptr() - p));
      if (n < 0) {
        if (errno == EINTR) continue;
        error_ = errno;
        return false;
      }
      if (n == 0) {  // a device that takes nothing: report it rather than spin
        error_ = EIO;
        return false;
      }
      p += n;
    }
    setp(data_, data_ + sizeof data_);
    return true;
  }

  int fd_;
  int error_ = 0;
  char data_[64 * 1024];
};

AtomicOutputFile::AtomicOutputFile(std::filesystem::path path) : path_(std::move(path)) {
  struct stat st {};
  if (::stat(path_.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) {
      throw OutputFileError(path_.string() + ": is a directory; expected the name of a file to write");
    }
    direct_ = true;
    temp_ = path_;
    fd_ = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd_ < 0) throw OutputFileError(path_.string() + ": cannot open for writing: " + std::strerror(errno));
  } else {
    if (!path_.has_filename()) {
      throw OutputFileError(path_.string() + ": expected the name of a file to write, not a directory");
    }
    // The pid keeps two processes writing the same target apart; the counter,
    // two writers in one process or a stale file left by a killed process.
    const std::string stem = path_.filename().string() + "." + std::to_string(::getpid());
    for (int attempt = 0; fd_ < 0; ++attempt) {
      temp_ = path_;
      std::string name = stem;
      if (attempt > 0) name += '-' + std::to_string(attempt);  // not "-" + ...: GCC 12 -O3's false warning
      temp_.replace_filename(name + ".tmp");
      fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (fd_ < 0 && (errno != EEXIST || attempt >= 100)) {
        throw OutputFileError(path_.string() + ": cannot create the file (as " + temp_.string() + " first): " +
                              std::strerror(errno));
      }
    }
  }
  buffer_ = std::make_unique<Buffer>(fd_);
  stream_ = std::make_unique<std::ostream>(buffer_.get());
}

AtomicOutputFile::~AtomicOutputFile() {
  if (!committed_) discard();
}

std::ostream& AtomicOutputFile::stream() { return *stream_; }

void AtomicOutputFile::discard() noexcept {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (!direct_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicOutputFile::fail(std::string_view action, int error) {
  discard();
  committed_ = true;  // nothing left to clean up
  throw OutputFileError(path_.string() + ": " + std::string(action) + ": " + std::strerror(error) +
                        (direct_ ? "" : "; nothing was written there"));
}

void AtomicOutputFile::check() {
  if (committed_) return;
  if (buffer_->error() != 0) fail("cannot write", buffer_->error());
  if (!*stream_) fail("cannot write", EIO);
}

void AtomicOutputFile::commit() {
  if (committed_) return;
  stream_->flush();
  check();
  // Some file systems (NFS, quotas) report a full disk only here.
  if (!direct_ && ::fsync(fd_) != 0) fail("cannot write", errno);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("cannot write", errno);
  if (!direct_ && ::rename(temp_.c_str(), path_.c_str()) != 0) {
    fail("cannot replace it with " + temp_.string(), errno);
  }
  committed_ = true;
}

void write_file_atomically(const std::filesystem::path& path, std::string_view text) {
  AtomicOutputFile file(path);
  file.stream().write(text.data(), static_cast<std::streamsize>(text.size()));
  file.commit();
}

void refuse_output_over_input(const std::filesystem::path& input, const std::filesystem::path& output,
                              std::string_view input_option, std::string_view output_option) {
  std::error_code ec;  // an output that does not exist yet cannot be the input
  if (std::filesystem::equivalent(input, output, ec) && !ec) {
    throw OutputFileError(std::string(output_option) + " " + output.string() + " is the same file as " +
                          std::string(input_option) + " " + input.string() +
                          "; writing it would destroy the input. Choose another output file");
  }
}

}  // namespace hapticlab
