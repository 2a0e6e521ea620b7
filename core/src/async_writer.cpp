#include "core/async_writer.hpp"

#include <utility>

namespace lbdem::io {

BackgroundWriter::BackgroundWriter() : thread_([this] { loop(); }) {}

BackgroundWriter::~BackgroundWriter() {
  {
    std::lock_guard<std::mutex> lk(m_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void BackgroundWriter::submit(std::function<void()> job) {
  std::lock_guard<std::mutex> lk(m_);
  if (error_) std::rethrow_exception(error_);
  jobs_.push_back(std::move(job));
  cv_.notify_all();
}

void BackgroundWriter::wait() {
  std::unique_lock<std::mutex> lk(m_);
  cv_.wait(lk, [this] { return (jobs_.empty() && !running_) || error_; });
  if (error_) std::rethrow_exception(error_);
}

bool BackgroundWriter::busy() const {
  std::lock_guard<std::mutex> lk(m_);
  return running_ || !jobs_.empty();
}

void BackgroundWriter::loop() {
  std::unique_lock<std::mutex> lk(m_);
  for (;;) {
    cv_.wait(lk, [this] { return stop_ || !jobs_.empty(); });
    if (jobs_.empty()) return;  // stop requested and nothing left
    std::function<void()> job = std::move(jobs_.front());
    jobs_.pop_front();
    if (error_) continue;  // after a failure the rest is dropped
    running_ = true;
    lk.unlock();
    std::exception_ptr err;
    try {
      job();
    } catch (...) {
      err = std::current_exception();
    }
    lk.lock();
    running_ = false;
    if (err && !error_) error_ = err;
    cv_.notify_all();
  }
}

}  // namespace lbdem::io
