#include "burrbench/watch/background.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>

namespace burrbench::watch {

BackgroundWatch::BackgroundWatch(WatchOptions options) : options_(std::move(options)) {
  result_ = done_.get_future();
  std::promise<void> ready;
  auto started = ready.get_future();
  options_.stop = &stop_;
  options_.exit_at_end = true;
  const auto on_url = options_.on_url;
  thread_ = std::thread([this, on_url, ready = std::move(ready)]() mutable {
    // Below every thread of the acquisition (the HTTP server's threads, started from
    // here, inherit it): a busy page costs the pollers nothing they could have used.
    (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 10);
    bool is_ready = false;
    WatchOptions o = options_;
    o.on_url = [&](const std::string& url) {
      if (on_url) on_url(url);
      is_ready = true;
      ready.set_value();
    };
    try {
      done_.set_value(run_watch(o));
    } catch (...) {
      if (!is_ready) ready.set_exception(std::current_exception());
      done_.set_exception(std::current_exception());
    }
  });
  try {
    started.get();
  } catch (...) {
    thread_.join();
    throw;
  }
}

BackgroundWatch::~BackgroundWatch() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

WatchSummary BackgroundWatch::finish(double timeout_s, std::string* error) {
  if (result_.wait_for(std::chrono::duration<double>(timeout_s)) != std::future_status::ready)
    stop_ = true;
  if (thread_.joinable()) thread_.join();
  try {
    return result_.get();
  } catch (const std::exception& e) {
    if (error) *error = e.what();
  }
  return {};
}

}  // namespace burrbench::watch
