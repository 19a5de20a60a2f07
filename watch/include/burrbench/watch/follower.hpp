#pragma once
// Follows an acquisition journal while `burrbench acquire` writes it. Read-only: the file
// is opened for reading only, never locked, and each poll reads it afresh through the
// same reader `recover` uses (rig::read_journal), so the writer never waits for the
// watcher. The follower keeps the file open, so when acquire removes the journal after
// writing the recording, the last poll still reads all of it. The writer appends whole 4096-byte
// blocks (one page) and never rewrites them, so a poll sees whole blocks plus at most a torn tail,
// which it ignores.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "burrbench/data_schema/recording.hpp"
#include "burrbench/rig/journal.hpp"

namespace burrbench::watch {

struct FollowUpdate {
  bool present = false;  // the journal exists and its header could be read
  bool ended = false;    // the writer finished it (end record), or removed it after that
  // Everything recorded so far, decoded as `recover` would (empty until a sample came).
  std::optional<data_schema::Recording> recording;
  std::vector<rig::JournalEvent> new_events;  // the session's events since the last poll
  std::vector<std::string> new_problems;      // damaged blocks found since the last poll
  std::size_t samples = 0, blocks = 0;        // in the journal so far
};

class JournalFollower {
 public:
  explicit JournalFollower(std::filesystem::path journal);
  ~JournalFollower();
  JournalFollower(const JournalFollower&) = delete;
  JournalFollower& operator=(const JournalFollower&) = delete;
  // Reads the journal as it is now. InputError when the file is not a journal (once it is
  // two blocks long, i.e. past the header the writer makes durable before anything else).
  FollowUpdate poll();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;  // the journal, opened for reading at the first poll that finds it
  bool seen_ = false, ended_ = false;
  std::size_t events_seen_ = 0, corrupt_seen_ = 0;
};

}  // namespace burrbench::watch
