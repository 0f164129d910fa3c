// Makes a plan command's --out folder and proves it writable (plan_folder.h).
#include "planning/plan_folder.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>

#include <unistd.h>

namespace hapticlab::planning {

namespace fs = std::filesystem;

void prepare_plan_folder(const fs::path& out) {
  if (out.empty()) throw std::runtime_error("--out is empty: name a folder to write into; nothing was simulated");
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw std::runtime_error("--out '" + out.string() + "': exists and is not a folder; nothing was simulated");
  fs::create_directories(out, ec);
  if (ec)
    throw std::runtime_error("--out '" + out.string() + "': cannot make the folder (" + ec.message() +
                             "); nothing was simulated");
  const fs::path probe = out / (".hapticlab-write-check-" + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    f << "x";
    f.flush();
    if (!f) {
      const std::string why = std::strerror(errno);
      fs::remove(probe, ec);
      throw std::runtime_error("--out '" + out.string() + "': cannot write in the folder (" + why +
                               "); nothing was simulated");
    }
  }
  fs::remove(probe, ec);
}

}  // namespace hapticlab::planning
