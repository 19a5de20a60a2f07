// The journal survives what a crash does to a file: a torn tail and damaged bytes cost
// only the block they hit; everything else reads back exactly.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/journal.hpp"

using namespace burrbench::rig;
namespace fs = std::filesystem;

namespace {
fs::path temp_path(const std::string& name) {
  auto p = fs::temp_directory_path() / ("bb_journal_" + std::to_string(::getpid()) + "_" + name);
  fs::remove(p);
  return p;
}
JournalSample sample(std::int64_t i) {
  JournalSample s;
  s.device = static_cast<std::uint16_t>(i % 3);
  s.t_send_ns = 1000 * i;
  s.t_recv_ns = 1000 * i + 500;
  s.counter = i;
  for (int k = 0; k < 42; ++k) s.regs.push_back(static_cast<std::uint16_t>(i * 7 + k));
  return s;
}
// Writes n samples, syncing every `per_sync`, returns the path.
fs::path write(const std::string& name, int n, int per_sync) {
  const auto p = temp_path(name);
  JournalWriter w(p, std::string(5000, 'h'));  // header spans two records
  for (int i = 0; i < n; ++i) {
    w.append(sample(i));
    if (i % 100 == 0) w.append(JournalEvent{i, 1, "gap", "detail " + std::to_string(i)});
    if ((i + 1) % per_sync == 0) w.sync();
  }
  w.finish();
  return p;
}
}  // namespace

TEST(Journal, RoundTripsExactly) {
  const auto p = write("rt", 2000, 64);
  const auto j = read_journal(p);
  EXPECT_TRUE(j.clean_end);
  EXPECT_EQ(j.header_json, std::string(5000, 'h'));
  ASSERT_EQ(j.samples.size(), 2000u);
  for (int i = 0; i < 2000; ++i) {
    const auto want = sample(i);
    EXPECT_EQ(j.samples[i].device, want.device);
    EXPECT_EQ(j.samples[i].t_send_ns, want.t_send_ns);
    EXPECT_EQ(j.samples[i].t_recv_ns, want.t_recv_ns);
    EXPECT_EQ(j.samples[i].counter, want.counter);
    EXPECT_EQ(j.samples[i].regs, want.regs);
  }
  EXPECT_EQ(j.events.size(), 20u);
  EXPECT_EQ(j.events[3].detail, "detail 300");
  EXPECT_EQ(fs::file_size(p) % kJournalBlockSize, 0u);
  fs::remove(p);
}

TEST(Journal, RefusesToOverwrite) {
  const auto p = write("ow", 10, 5);
  EXPECT_THROW(JournalWriter(p, "{}"), burrbench::InputError);
  fs::remove(p);
}

TEST(Journal, FlippedByteCostsOneBlock) {
  const auto p = write("flip", 3000, 3000);
  const auto clean = read_journal(p);
  const auto blocks = fs::file_size(p) / kJournalBlockSize;
  ASSERT_GT(blocks, 10u);
  for (std::size_t b : {std::size_t{0}, std::size_t{5}, blocks - 2}) {
    for (std::size_t off : {std::size_t{3}, std::size_t{100}, std::size_t{2000}}) {
      const auto q = temp_path("flip_copy");
      fs::copy_file(p, q);
      {
        std::fstream f(q, std::ios::in | std::ios::out | std::ios::binary);
        f.seekg(static_cast<std::streamoff>(b * kJournalBlockSize + off));
        char c;
        f.read(&c, 1);
        c = static_cast<char>(c ^ 0x5A);
        f.seekp(static_cast<std::streamoff>(b * kJournalBlockSize + off));
        f.write(&c, 1);
      }
      const auto j = read_journal(q);
      EXPECT_EQ(j.corrupt_blocks, 1u) << b << "/" << off;
      // Header blocks hold no samples; any other damaged block costs its samples only.
      const std::size_t per_block = (kJournalBlockSize - 20) / (8 + 28 + 84);
      EXPECT_GE(j.samples.size() + per_block, clean.samples.size()) << b << "/" << off;
      if (b < 2) EXPECT_EQ(j.samples.size(), clean.samples.size());
      else EXPECT_LT(j.samples.size(), clean.samples.size());
      // Surviving samples are intact and in order.
      for (std::size_t i = 1; i < j.samples.size(); ++i) EXPECT_LT(j.samples[i - 1].counter, j.samples[i].counter);
      fs::remove(q);
    }
  }
  fs::remove(p);
}

TEST(Journal, TornTailIsIgnored) {
  const auto p = write("torn", 1000, 50);
  const auto clean = read_journal(p);
  const auto size = fs::file_size(p);
  fs::resize_file(p, size - kJournalBlockSize / 2);  // the last block half-written
  const auto j = read_journal(p);
  EXPECT_EQ(j.torn_tail_bytes, kJournalBlockSize / 2);
  EXPECT_FALSE(j.clean_end);
  EXPECT_LE(j.samples.size(), clean.samples.size());
  EXPECT_GE(j.samples.size() + 40, clean.samples.size());
  fs::remove(p);
}

TEST(Journal, NotAJournalIsAnInputError) {
  const auto p = temp_path("junk");
  std::ofstream(p) << std::string(10000, 'x');
  EXPECT_THROW(read_journal(p), burrbench::InputError);
  fs::remove(p);
}
