#pragma once
// The event feed between the watcher's loop and the page's connections: an append-only
// list of JSON messages (the Server-Sent Events' data), each connection reading on from
// its own position, so a page opened late sees the session from its start.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

namespace burrbench::watch {

class Feed {
 public:
  void publish(std::string json);
  // The messages from `next` on (advancing it); waits up to `wait` for one to come.
  std::vector<std::string> since(std::size_t& next, std::chrono::milliseconds wait);
  void close();  // no more messages: connections end once they have read them all
  bool closed() const;
  std::size_t size() const;

 private:
  mutable std::mutex m_;
  std::condition_variable cv_;
  std::vector<std::string> messages_;
  bool closed_ = false;
};

}  // namespace burrbench::watch
