#pragma once
// Output that does not stall the run: jobs (writing a snapshot already copied
// to host memory) run in order on one host thread while the caller goes on
// stepping the GPU. Every HDF5 call of a run must then go through this thread
// (the HDF5 library is not thread-safe): a scene that writes in the background
// hands all its HDF5 writers' calls to it.
//
// A failed job (disk full, ...) is rethrown by the next submit() or wait() on
// the caller's thread, with its own type (ResourceError keeps exit code 4);
// later jobs are dropped. The destructor waits for the queue and swallows a
// failure nobody asked for (call wait() before the run ends to see it).
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace lbdem::io {

class BackgroundWriter {
 public:
  BackgroundWriter();
  ~BackgroundWriter();
  BackgroundWriter(const BackgroundWriter&) = delete;
  BackgroundWriter& operator=(const BackgroundWriter&) = delete;

  // Queues a job; returns at once. Rethrows the failure of an earlier job.
  void submit(std::function<void()> job);
  // Returns when every queued job has finished; rethrows the first failure.
  void wait();
  // Jobs queued or running.
  bool busy() const;

 private:
  void loop();
  mutable std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;
  bool running_ = false;  // a job is executing
  bool stop_ = false;
  std::exception_ptr error_;
  std::thread thread_;
};

}  // namespace lbdem::io
