// The follower reads a journal while a real JournalWriter appends to it: it sees every
// sample and event once they are synced, never changes the file, and tells the end.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/finalise.hpp"
#include "burrbench/rig/journal.hpp"
#include "burrbench/rig/register_map.hpp"
#include "burrbench/watch/follower.hpp"
#include "temp_dir.hpp"

namespace br = burrbench::rig;
namespace bw = burrbench::watch;
namespace fs = std::filesystem;

namespace {

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string header_json(const std::string& map_text) {
  br::SessionHeader h;
  h.rig_file = "virtual.toml";
  h.rig_toml = map_text;
  h.sample_id = "S1";
  h.session_wall_ns = 1'700'000'000'000'000'000LL;
  h.session_monotonic_ns = 1'000'000'000LL;
  return br::to_json(h).dump();
}

}  // namespace

TEST(WatchFollower, FollowsAGrowingJournalReadOnly) {
  burrbench::test::TempDir dir("bb-watch");
  const fs::path journal = dir / "r.h5.journal";
  bw::JournalFollower f(journal);
  {
    const auto u = f.poll();  // not written yet
    EXPECT_FALSE(u.present);
    EXPECT_FALSE(u.ended);
    EXPECT_FALSE(u.recording.has_value());
  }
  const std::string map_text =
      read_file(fs::path(BURRBENCH_SOURCE_DIR) / "examples/rigs/virtual.toml");
  const br::RigMap map = br::parse_rig_map(map_text, "virtual.toml");
  br::JournalWriter w(journal, header_json(map_text));
  {
    const auto u = f.poll();  // the header only
    EXPECT_TRUE(u.present);
    EXPECT_EQ(u.samples, 0u);
    EXPECT_FALSE(u.recording.has_value());
  }
  std::int64_t t = 1'100'000'000LL;
  std::size_t written = 0;
  for (int round = 0; round < 5; ++round) {
    for (int i = 0; i < 40; ++i, t += 1'000'000)
      for (std::size_t d = 0; d < map.devices.size(); ++d) {
        br::JournalSample s;
        s.device = std::uint16_t(d);
        s.t_send_ns = t;
        s.t_recv_ns = t + 100'000;
        s.counter = 40 * round + i;
        s.regs.assign(std::size_t(map.devices[d].sample_registers()), 0);
        w.append(s);
        ++written;
      }
    w.append(br::JournalEvent{t, 0, "gap", "round " + std::to_string(round)});
    w.sync();
    const std::string before = read_file(journal);
    const auto u = f.poll();
    EXPECT_EQ(read_file(journal), before);  // polling changed nothing
    EXPECT_EQ(u.samples, written);
    ASSERT_EQ(u.new_events.size(), 1u) << "round " << round;  // each event once
    EXPECT_EQ(u.new_events[0].detail, "round " + std::to_string(round));
    ASSERT_TRUE(u.recording.has_value());
    EXPECT_EQ(u.recording->streams.size(), map.devices.size());
    EXPECT_EQ(u.recording->streams[0].samples(), std::size_t(40 * (round + 1)));
    EXPECT_FALSE(u.ended);
  }
  // A torn tail (a block being written) is not damage and hides nothing synced.
  {
    std::ofstream tail(journal, std::ios::binary | std::ios::app);
    tail << std::string(1000, 'x');
  }
  {
    const auto u = f.poll();
    EXPECT_TRUE(u.new_problems.empty());
    EXPECT_EQ(u.samples, written);
  }
}

TEST(WatchFollower, TellsTheEndAndARemovedJournal) {
  burrbench::test::TempDir dir("bb-watch");
  const fs::path journal = dir / "r.h5.journal";
  const std::string map_text =
      read_file(fs::path(BURRBENCH_SOURCE_DIR) / "examples/rigs/virtual.toml");
  {
    br::JournalWriter w(journal, header_json(map_text));
    bw::JournalFollower f(journal);
    EXPECT_FALSE(f.poll().ended);
    w.finish();
    EXPECT_TRUE(f.poll().ended);
    fs::remove(journal);  // acquire removes it once the recording is written
    EXPECT_TRUE(f.poll().ended);
  }
  // A journal removed without an end record seen: ended too (the writer is gone).
  {
    br::JournalWriter w(journal, header_json(map_text));
    bw::JournalFollower f(journal);
    EXPECT_TRUE(f.poll().present);
    fs::remove(journal);
    EXPECT_TRUE(f.poll().ended);
  }
}

TEST(WatchFollower, NotAJournalIsBadInput) {
  burrbench::test::TempDir dir("bb-watch");
  const fs::path p = dir / "junk.journal";
  std::ofstream(p, std::ios::binary) << std::string(3 * br::kJournalBlockSize, 'j');
  bw::JournalFollower f(p);
  EXPECT_THROW(f.poll(), burrbench::InputError);
}

TEST(WatchFollower, ReadsTheLastBlocksOfAJournalRemovedBeforeItsLastPoll) {
  // acquire writes its last blocks and the end record, the recording, and removes the
  // journal, possibly all between two polls: the follower's open file still holds them.
  burrbench::test::TempDir dir("bb-watch");
  const fs::path journal = dir / "r.h5.journal";
  const std::string map_text =
      read_file(fs::path(BURRBENCH_SOURCE_DIR) / "examples/rigs/virtual.toml");
  const br::RigMap map = br::parse_rig_map(map_text, "virtual.toml");
  br::JournalWriter w(journal, header_json(map_text));
  bw::JournalFollower f(journal);
  auto append = [&](int n, std::int64_t t0) {
    for (int i = 0; i < n; ++i) {
      br::JournalSample s;
      s.device = 0;
      s.t_send_ns = t0 + i * 1'000'000LL;
      s.t_recv_ns = s.t_send_ns + 100'000;
      s.counter = i;
      s.regs.assign(std::size_t(map.devices[0].sample_registers()), 0);
      w.append(s);
    }
  };
  append(100, 1'100'000'000LL);
  w.sync();
  EXPECT_EQ(f.poll().samples, 100u);
  append(300, 1'300'000'000LL);
  w.finish();
  fs::remove(journal);
  const auto u = f.poll();
  EXPECT_TRUE(u.ended);
  EXPECT_EQ(u.samples, 400u);
  ASSERT_TRUE(u.recording.has_value());
  EXPECT_TRUE(f.poll().ended);
}
