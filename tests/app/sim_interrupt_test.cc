// Ctrl-C in `sim run` and `sim replay`, sent to the real binary: the loop
// stops, the output's temporary file is removed, the command says that
// nothing was written and exits 130 (the top-level help's status for
// Ctrl-C). Before, SIGINT killed the process with the default action, the
// AtomicOutputFile's destructor never ran, and OUT.<pid>.tmp stayed.
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/testing/child_process.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class SimInterruptTest : public ::testing::Test {
 protected:
  // The files of the scratch folder other than `keep` (the inputs).
  std::vector<std::string> outputs(const std::vector<std::string>& keep) const {
    std::vector<std::string> names;
    for (const fs::directory_entry& e : fs::directory_iterator(dir_)) {
      const std::string name = e.path().filename().string();
      if (std::find(keep.begin(), keep.end(), name) == keep.end()) names.push_back(name);
    }
    return names;
  }

  // Starts `args`, waits until the output's temporary file exists (the
  // loop is then running), sends SIGINT; returns the exit status (-signal
  // when a signal ended it) and the output.
  std::pair<int, std::string> interrupt(const std::vector<std::string>& args, const std::vector<std::string>& inputs) {
    std::vector<std::string> argv{HAPTICLAB_CLI_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    testing::ChildProcess child(argv, (log_dir_.path() / "log").string());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (child.running() && outputs(inputs).empty() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    EXPECT_TRUE(child.running()) << "ended before it could be interrupted: " << child.output();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // well inside the loop
    child.kill(SIGINT);
    int status = 0;
    for (int i = 0; i < 300 && child.running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (child.running()) {
      ADD_FAILURE() << "still running 6 s after SIGINT";
      child.kill(SIGKILL);
    }
    status = child.wait();
    return {status, child.output()};
  }

  hapticlab::testing::ScratchDir scratch_{"hapticlab_sim_interrupt_"};
  hapticlab::testing::ScratchDir log_dir_{"hapticlab_sim_interrupt_log_"};
  const fs::path dir_ = scratch_.path();
  const fs::path settings_ = fs::path(HAPTICLAB_SOURCE_DIR) / "examples/settings/high_fidelity.json";
};

TEST_F(SimInterruptTest, CtrlCInSimRunRemovesTheTemporaryFileAndExits130) {
  const fs::path out = dir_ / "w.csv";
  const auto [status, text] = interrupt({"sim", "run", "--settings", settings_.string(), "--clock", "wall",
                                         "--max-trial-s", "60", "--out", out.string()},
                                        {});
  EXPECT_EQ(status, 130) << text;
  EXPECT_THAT(text, HasSubstr("hapticlab sim run: stopped by Ctrl-C (or SIGTERM)"));
  EXPECT_THAT(text, HasSubstr("nothing was written to " + out.string()));
  EXPECT_THAT(outputs({}), ::testing::IsEmpty()) << "neither " << out << " nor its temporary file may be left";
}

TEST_F(SimInterruptTest, CtrlCInSimReplayRemovesTheTemporaryFileAndExits130) {
  // A recording of 3500 s (a longer one is refused as more than a trial
  // may last): on the virtual clock its replay of 3.5 M updates, each
  // written, runs for many seconds, so the SIGINT comes while the loop runs.
  const fs::path csv = dir_ / "long.csv";
  {
    std::ofstream f(csv);
    f << "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n";
    for (int k = 0; k <= 3500; ++k)
      for (int instrument = 0; instrument < 2; ++instrument)
        f << k << ',' << instrument << ",0.05," << (k % 2 ? 0.01 : -0.01) << ",0,0,0,0\n";
  }
  const fs::path out = dir_ / "r.csv";
  const auto [status, text] = interrupt({"sim", "replay", "--csv", csv.string(), "--task", "clip", "--settings",
                                         settings_.string(), "--out", out.string()},
                                        {"long.csv"});
  EXPECT_EQ(status, 130) << text;
  EXPECT_THAT(text, HasSubstr("hapticlab sim replay: stopped by Ctrl-C (or SIGTERM)"));
  EXPECT_THAT(text, HasSubstr("nothing was written to " + out.string()));
  EXPECT_THAT(outputs({"long.csv"}), ::testing::IsEmpty()) << "neither " << out << " nor its temporary file may be left";
}

}  // namespace
}  // namespace hapticlab::app
