// Downloads stay inside the console's folders (console/served_file.h).
#include "console/served_file.h"

#include <unistd.h>

#include <fstream>

#include <gtest/gtest.h>

namespace hapticlab::console {
namespace {

TEST(ServedFileTest, OnlyPlainFilesInsideTheFolder) {
  const auto root = std::filesystem::temp_directory_path() / ("served_" + std::to_string(::getpid()));
  const auto outside = root.parent_path() / ("served_outside_" + std::to_string(::getpid()));
  std::filesystem::create_directories(root / "figures");
  std::filesystem::create_directories(outside);
  std::ofstream(root / "report.html") << "r";
  std::ofstream(root / "figures" / "f1.svg") << "f";
  std::ofstream(outside / "secret.db") << "s";
  std::filesystem::create_symlink(outside / "secret.db", root / "link.db");
  std::filesystem::create_directory_symlink(outside, root / "out");

  EXPECT_EQ(served_file(root, "report.html"), std::filesystem::weakly_canonical(root / "report.html"));
  EXPECT_EQ(served_file(root, "figures/f1.svg"), std::filesystem::weakly_canonical(root / "figures" / "f1.svg"));
  for (const char* bad : {"", "..", "../served", "figures/../report.html", "/etc/passwd", "figures//f1.svg",
                          "figures/", ".hidden", "figures", "no_such_file", "link.db", "out/secret.db",
                          "report.html%00", "a b"})
    EXPECT_EQ(served_file(root, bad), std::nullopt) << bad;
  std::filesystem::remove_all(root);
  std::filesystem::remove_all(outside);
}

}  // namespace
}  // namespace hapticlab::console
