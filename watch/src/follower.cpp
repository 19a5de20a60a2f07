#include "burrbench/watch/follower.hpp"

#include <system_error>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/finalise.hpp"

namespace burrbench::watch {
namespace fs = std::filesystem;

JournalFollower::JournalFollower(fs::path journal) : path_(std::move(journal)) {}

FollowUpdate JournalFollower::poll() {
  FollowUpdate u;
  std::error_code ec;
  const auto size = fs::file_size(path_, ec);
  if (ec) {
    // acquire removes its journal once the recording is written: after an end record
    // that is the normal end; before one, the session ended without us seeing its end.
    u.ended = seen_;
    return u;
  }
  rig::JournalContents j;
  try {
    j = rig::read_journal(path_);
  } catch (const InputError&) {
    // The writer makes its two header blocks durable before anything else: until they
    // are there, the journal is still being created.
    if (size < 2 * rig::kJournalBlockSize) return u;
    throw;
  }
  seen_ = true;
  u.present = true;
  ended_ = ended_ || j.clean_end;
  u.ended = ended_;
  u.blocks = j.blocks;
  u.samples = j.samples.size();
  for (std::size_t i = events_seen_; i < j.events.size(); ++i) u.new_events.push_back(j.events[i]);
  events_seen_ = std::max(events_seen_, j.events.size());
  // A torn tail is the block being written: expected here, not damage.
  if (j.corrupt_blocks > corrupt_seen_)
    for (const auto& p : j.problems)
      if (p.rfind("torn tail", 0) != 0) u.new_problems.push_back(p);
  corrupt_seen_ = std::max(corrupt_seen_, j.corrupt_blocks);
  if (!j.samples.empty()) u.recording = rig::recording_from_journal(j, path_.string());
  return u;
}

}  // namespace burrbench::watch
