#pragma once
// The event feed between the watcher's loop and the page's connections: a list of JSON
// messages (the Server-Sent Events' data), each connection reading on from its own
// position, so a page opened late sees the session from its first message on — as far as
// the memory budget keeps it: beyond it the oldest messages are dropped (a connection
// behind them skips ahead), except the first (the page's setup), which every connection
// gets first.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace burrbench::watch {

class Feed {
 public:
  // 64 MiB: about five minutes of a 1 kHz session's batches.
  explicit Feed(std::size_t budget_bytes = std::size_t(64) << 20) : budget_bytes_(budget_bytes) {}
  void publish_first(std::string json);  // once, before the others
  void publish(std::string json);
  // The messages from position `next` on (0: from the first), advancing it; waits up to
  // `wait` for one to come.
  std::vector<std::string> since(std::size_t& next, std::chrono::milliseconds wait);
  void close();  // no more messages: connections end once they have read them all
  bool closed() const;
  std::size_t dropped() const;  // messages dropped for the budget

 private:
  mutable std::mutex m_;
  std::condition_variable cv_;
  std::optional<std::string> first_;
  std::deque<std::string> messages_;  // positions dropped_ + 1 … dropped_ + size()
  std::size_t dropped_ = 0, bytes_ = 0, budget_bytes_;
  bool closed_ = false;
};

}  // namespace burrbench::watch
