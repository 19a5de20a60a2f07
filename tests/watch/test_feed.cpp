// The feed: every connection reads every message from its own position; beyond the memory
// budget the oldest go (a reader behind them skips ahead), the first message never.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>

#include "burrbench/watch/feed.hpp"

namespace bw = burrbench::watch;
using std::chrono::milliseconds;

TEST(WatchFeed, EachReaderFromItsOwnPosition) {
  bw::Feed f;
  f.publish_first("hello");
  f.publish("a");
  std::size_t r1 = 0, r2 = 0;
  EXPECT_EQ(f.since(r1, milliseconds(0)), (std::vector<std::string>{"hello", "a"}));
  f.publish("b");
  EXPECT_EQ(f.since(r1, milliseconds(0)), (std::vector<std::string>{"b"}));
  EXPECT_EQ(f.since(r2, milliseconds(0)), (std::vector<std::string>{"hello", "a", "b"}));
  EXPECT_TRUE(f.since(r1, milliseconds(0)).empty());
}

TEST(WatchFeed, WaitsForTheNextMessage) {
  bw::Feed f;
  f.publish_first("hello");
  std::size_t r = 0;
  f.since(r, milliseconds(0));
  std::thread writer([&] {
    std::this_thread::sleep_for(milliseconds(50));
    f.publish("late");
  });
  const auto t0 = std::chrono::steady_clock::now();
  const auto got = f.since(r, milliseconds(5000));
  writer.join();
  EXPECT_EQ(got, (std::vector<std::string>{"late"}));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, milliseconds(4000));  // woken, not timed out
}

TEST(WatchFeed, BudgetDropsTheOldestButNeverTheFirst) {
  bw::Feed f(10);  // bytes: room for two 4-byte messages
  f.publish_first("hello");
  std::size_t mid = 0;
  f.publish("m001");
  EXPECT_EQ(f.since(mid, milliseconds(0)), (std::vector<std::string>{"hello", "m001"}));
  for (int i = 2; i <= 5; ++i) f.publish("m00" + std::to_string(i));
  EXPECT_EQ(f.dropped(), 3u);
  // A reader behind the dropped ones skips ahead; a new one gets the first, then the kept.
  EXPECT_EQ(f.since(mid, milliseconds(0)), (std::vector<std::string>{"m004", "m005"}));
  std::size_t late = 0;
  EXPECT_EQ(f.since(late, milliseconds(0)), (std::vector<std::string>{"hello", "m004", "m005"}));
  f.close();
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.since(late, milliseconds(1000)).empty());  // closed: no wait
}
