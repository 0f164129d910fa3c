// Output files are complete or absent: real files, a real full device
// (/dev/full) and a real file size limit in a child process.
#include "core/common/output_file.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class OutputFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / (std::string("output_file_test_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::size_t files_in_dir() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++n;
    return n;
  }

  fs::path dir_;
};

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST_F(OutputFileTest, CommitReplacesTheTargetAndLeavesNoTemporaryFile) {
  const fs::path target = dir_ / "out.csv";
  std::ofstream(target) << "old\n";
  {
    AtomicOutputFile file(target);
    file.stream() << "new\n";
    EXPECT_EQ(read_all(target), "old\n");  // untouched until commit
    EXPECT_TRUE(fs::exists(file.temp_path()));
    file.commit();
  }
  EXPECT_EQ(read_all(target), "new\n");
  EXPECT_EQ(files_in_dir(), 1u);
}

TEST_F(OutputFileTest, WithoutCommitNothingIsLeft) {
  const fs::path target = dir_ / "out.csv";
  {
    AtomicOutputFile file(target);
    file.stream() << std::string(200000, 'x');  // more than the buffer: bytes reached the disk
  }
  EXPECT_EQ(files_in_dir(), 0u);
}

TEST_F(OutputFileTest, FullDeviceNamesThePathAndTheCause) {
  // Through a link, so a broken class replaces the link, not /dev/full.
  const fs::path target = dir_ / "full.csv";
  fs::create_symlink("/dev/full", target);
  AtomicOutputFile file(target);
  file.stream() << "x\n";
  try {
    file.commit();
    FAIL() << "writing /dev/full succeeded";
  } catch (const OutputFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr(target.string() + ": cannot write: No space left on device"));
  }
  EXPECT_TRUE(fs::is_symlink(target));
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
}

TEST_F(OutputFileTest, MissingDirectoryNamesThePath) {
  try {
    AtomicOutputFile file(dir_ / "no_such_dir" / "out.csv");
    FAIL();
  } catch (const OutputFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no_such_dir/out.csv: cannot create the file"));
    EXPECT_THAT(e.what(), HasSubstr("No such file or directory"));
  }
}

TEST_F(OutputFileTest, DirectoryIsNotAFileName) {
  EXPECT_THROW(AtomicOutputFile{dir_}, OutputFileError);
}

// A file size limit makes write() fail with EFBIG part-way through, as a full
// disk does with ENOSPC; the limit is set in a child so the test process
// keeps its own.
TEST_F(OutputFileTest, FileSizeLimitLeavesNoPartialFile) {
  const fs::path target = dir_ / "big.csv";
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::close(pipe_fds[0]);
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    std::string message = "committed";
    try {
      AtomicOutputFile file(target);
      file.stream() << std::string(100000, 'x');
      file.commit();
    } catch (const OutputFileError& e) {
      message = e.what();
    }
    [[maybe_unused]] const auto n = ::write(pipe_fds[1], message.data(), message.size());
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  std::string message;
  char buffer[512];
  for (ssize_t n; (n = ::read(pipe_fds[0], buffer, sizeof buffer)) > 0;) message.append(buffer, static_cast<std::size_t>(n));
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_THAT(message, HasSubstr(target.string() + ": cannot write: File too large"));
  EXPECT_EQ(files_in_dir(), 0u) << "a partial or temporary file was left";
}

TEST_F(OutputFileTest, OutputOverInputIsRefused) {
  const fs::path input = dir_ / "in.csv";
  std::ofstream(input) << "data\n";
  fs::create_symlink(input, dir_ / "link.csv");
  EXPECT_THROW(refuse_output_over_input(input, dir_ / "link.csv", "--input", "--output"), OutputFileError);
  EXPECT_THROW(refuse_output_over_input(input, dir_ / "." / "in.csv", "--input", "--output"), OutputFileError);
  EXPECT_NO_THROW(refuse_output_over_input(input, dir_ / "new.csv", "--input", "--output"));
  try {
    refuse_output_over_input(input, input, "--input", "--output");
  } catch (const OutputFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("is the same file as --input"));
  }
}

}  // namespace
}  // namespace hapticlab
