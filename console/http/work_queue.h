#pragma once
// Threads for the requests that may take long (a control that writes the
// study database, a read of the whole study), so the server's event loop
// never waits on them: a fixed number of threads and a bounded queue. A
// full queue refuses at once (the caller answers 503) instead of growing.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace hapticlab::console::http {

class WorkQueue {
 public:
  // `threads` >= 1 run the tasks in the order posted (one thread: one after
  // the other, never two at once); at most `capacity` wait.
  WorkQueue(std::string name, std::size_t threads, std::size_t capacity);
  ~WorkQueue();  // runs what was posted, then joins
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;

  // False (and `task` not run) when `capacity` tasks already wait.
  bool post(std::function<void()> task);
  const std::string& name() const noexcept { return name_; }
  std::size_t capacity() const noexcept { return capacity_; }

 private:
  void work();

  const std::string name_;
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> tasks_;
  bool closing_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace hapticlab::console::http
