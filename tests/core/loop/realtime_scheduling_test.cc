#include "core/loop/realtime.h"

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <stdexcept>
#include <string>
#include <thread>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(Realtime, OffChangesNothing) {
  int policy_before = -1;
  sched_param param{};
  pthread_getschedparam(pthread_self(), &policy_before, &param);
  const RealtimeResult r = apply_realtime_to_this_thread(RealtimeOptions{});
  EXPECT_FALSE(r.scheduled);
  EXPECT_FALSE(r.pinned);
  int policy_after = -1;
  pthread_getschedparam(pthread_self(), &policy_after, &param);
  EXPECT_EQ(policy_after, policy_before);
}

TEST(Realtime, AppliesOrSaysWhyNot) {
  // Whether SCHED_FIFO is granted depends on who runs the test (root, an
  // rtprio limit, a container); either way the result must match what the
  // thread really got.
  RealtimeOptions options;
  options.enabled = true;
  options.priority = 10;
  options.cpu = 0;
  RealtimeResult r;
  int policy = -1;
  cpu_set_t set;
  std::thread([&] {
    r = apply_realtime_to_this_thread(options);
    sched_param param{};
    pthread_getschedparam(pthread_self(), &policy, &param);
    CPU_ZERO(&set);
    pthread_getaffinity_np(pthread_self(), sizeof set, &set);
  }).join();
  EXPECT_EQ(r.scheduled, policy == SCHED_FIFO);
  if (!r.scheduled) {
    EXPECT_NE(r.sched_errno, 0);
  }
  EXPECT_EQ(r.cpu, 0);
  if (r.pinned) {
    EXPECT_EQ(CPU_COUNT(&set), 1);
    EXPECT_TRUE(CPU_ISSET(0, &set));
  }
  const std::string line = prepare_realtime(options);
  EXPECT_NE(line.find(r.scheduled ? "SCHED_FIFO priority 10" : "SCHED_FIFO refused"), std::string::npos) << line;
}

TEST(Realtime, RefusesAPriorityOrCpuOutOfRange) {
  RealtimeOptions options;
  options.enabled = true;
  options.priority = 0;
  EXPECT_THROW(prepare_realtime(options), std::invalid_argument);
  options.priority = 100;
  EXPECT_THROW(prepare_realtime(options), std::invalid_argument);
  options.priority = 50;
  options.cpu = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN));
  try {
    prepare_realtime(options);
    FAIL() << "a CPU the machine does not have was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("realtime-cpu"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hapticlab
