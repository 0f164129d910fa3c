#include "planning/plan_runner.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <set>
#include <thread>

#include "planning/power.h"

namespace hapticlab::planning {

PlanWork plan_work(const PlanInputs& inputs, PowerStore& store) {
  const std::set<std::pair<int, int>> done = store.done();
  PlanWork w;
  const std::vector<std::pair<int, int>> mine = inputs.studies_of_shard();
  for (const auto& study : mine)
    if (!done.count(study)) w.todo.push_back(study);
  w.total = mine.size();
  w.already = w.total - w.todo.size();
  return w;
}

std::size_t plan_jobs(std::size_t requested, std::size_t todo) {
  return std::min<std::size_t>(requested > 0 ? requested : 2 * std::max(1u, std::thread::hardware_concurrency()),
                               std::max<std::size_t>(1, todo));
}

PlanRunResult run_plan_studies(const protocols::Protocol& protocol, const std::vector<std::pair<int, int>>& todo,
                               PowerStore& store, const PlanRunOptions& options) {
  const auto interrupted = [&] { return options.interrupted && options.interrupted(); };
  const std::size_t jobs = std::max<std::size_t>(1, options.jobs);
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex m;
  std::condition_variable cv;
  std::deque<StudyOutcome> finished;
  std::exception_ptr error;
  std::size_t running = jobs;
  std::vector<std::thread> pool;
  for (std::size_t t = 0; t < jobs; ++t) {
    pool.emplace_back([&] {
      try {
        while (!interrupted() && !failed) {
          const std::size_t k = next++;
          if (k >= todo.size()) break;
          SimulatedStudyOptions study_sim = options.sim;
          if (!options.draws.empty())
            study_sim.population =
                options.draws[draw_of_group(draw_group(todo[k].second), options.draws.size())];
          StudyOutcome outcome = run_power_study(protocol, todo[k].first, todo[k].second, options.seed, study_sim);
          const std::lock_guard<std::mutex> lock(m);
          finished.push_back(std::move(outcome));
          cv.notify_one();
        }
      } catch (...) {
        const std::lock_guard<std::mutex> lock(m);
        if (!error) error = std::current_exception();
        failed = true;
      }
      const std::lock_guard<std::mutex> lock(m);
      --running;
      cv.notify_one();
    });
  }
  // Stored on this thread, as they finish: SQLite's connection is this one's.
  const auto started = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(); };
  PlanRunResult result;
  std::exception_ptr store_error;
  for (;;) {
    std::unique_lock<std::mutex> lock(m);
    cv.wait_for(lock, std::chrono::milliseconds(200), [&] { return !finished.empty() || running == 0; });
    std::deque<StudyOutcome> batch;
    batch.swap(finished);
    const bool all_stopped = running == 0;
    lock.unlock();
    for (const StudyOutcome& s : batch) {
      if (store_error) break;
      try {
        store.add(s);  // committed: an interrupted run keeps it
      } catch (...) {
        store_error = std::current_exception();
        failed = true;
        break;
      }
      ++result.stored;
      result.updates += s.updates;
    }
    if (options.on_progress) options.on_progress(result.stored, elapsed());
    if (all_stopped && batch.empty()) break;
  }
  for (std::thread& t : pool) t.join();
  result.elapsed_s = elapsed();
  if (store_error) {
    try {
      std::rethrow_exception(store_error);
    } catch (const std::exception& e) {
      throw PlanStoreFailure(e.what(), result.stored);
    }
  }
  if (error) std::rethrow_exception(error);
  return result;
}

}  // namespace hapticlab::planning
