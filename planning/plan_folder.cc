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

void prepare_plan_folder(const fs::path& out, const std::string& not_done) {
  if (out.empty()) throw std::runtime_error("--out is empty: name a folder to write into; " + not_done);
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw std::runtime_error("--out '" + out.string() + "': exists and is not a folder; " + not_done);
  fs::create_directories(out, ec);
  if (ec)
    throw std::runtime_error("--out '" + out.string() + "': cannot make the folder (" + ec.message() +
                             "); " + not_done);
  const fs::path probe = out / (".hapticlab-write-check-" + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    f << "x";
    f.flush();
    if (!f) {
      const std::string why = std::strerror(errno);
      fs::remove(probe, ec);
      throw std::runtime_error("--out '" + out.string() + "': cannot write in the folder (" + why +
                               "); " + not_done);
    }
  }
  fs::remove(probe, ec);
}

}  // namespace hapticlab::planning
