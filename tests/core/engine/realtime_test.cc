// The haptic-loop path must not allocate (design rule: no allocation, locks,
// I/O or exceptions after start). This binary replaces the global operator
// new to count allocations made while Engine::update runs.
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <thread>

#include <gtest/gtest.h>

#include "core/engine/engine.h"
#include "core/settings/settings_json.h"

namespace {
// Only the thread that runs the haptic loop counts; the settings writer may
// allocate (it validates and copies on its own thread).
thread_local bool counting = false;
std::atomic<long> allocations{0};
}  // namespace

// GCC cannot tell that these free() calls pair with the malloc() below.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  if (counting) allocations.fetch_add(1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace hapticlab {
namespace {

TEST(RealTimeTest, UpdatesNeverAllocateWhateverHappens) {
  const std::string dir = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/";
  EngineSettings a = load_settings_file(dir + "max_stable.json").engine;
  a.loop = {200.0, 0.02, 0.01};  // hold and latency buffers in use too
  const EngineSettings b = load_settings_file(dir + "all_degradations.json").engine;
  Engine engine(a);
  std::atomic<bool> stop{false};
  // Settings swaps from another thread while the loop runs.
  std::thread writer([&] {
    for (int i = 0; !stop.load(); ++i) engine.set_settings(i % 2 ? a : b);
  });
  const double nan = std::nan("");
  counting = true;
  double t = 0.0;
  for (int i = 0; i < 100000; ++i) {
    double dt = 1e-3;
    if (i % 5000 == 1000) dt = 0.03;    // sub-stepped
    if (i % 5000 == 2000) dt = 2.0;     // stall: re-anchor
    if (i % 5000 == 3000) dt = 1e-6;    // deferred
    t += dt;
    const JointVector q(0.1 + 0.02 * std::sin(3 * t), 0.2 * std::sin(t), 0.1 * std::cos(2 * t));
    const Eigen::Vector3d f = i % 5000 == 4000 ? Eigen::Vector3d(nan, 0, 0)
                                               : Eigen::Vector3d(0.2, -0.1, 0.8);
    engine.update(i % 2, {dt, q, f});
  }
  counting = false;
  stop = true;
  writer.join();
  EXPECT_EQ(allocations.load(), 0);
}

}  // namespace
}  // namespace hapticlab
