#include "burrbench/watch/follower.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <system_error>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/finalise.hpp"

namespace burrbench::watch {
namespace fs = std::filesystem;

JournalFollower::JournalFollower(fs::path journal) : path_(std::move(journal)) {}

JournalFollower::~JournalFollower() {
  if (fd_ >= 0) ::close(fd_);
}

FollowUpdate JournalFollower::poll() {
  FollowUpdate u;
  if (ended_) {  // read whole after its end once already: nothing more can come
    u.present = u.ended = true;
    return u;
  }
  if (fd_ < 0) {
    fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) {
      u.ended = seen_;
      return u;
    }
  }
  // acquire removes its journal once the recording is written: the open descriptor still
  // reads all of it, once more, and that is the end.
  std::error_code ec;
  const bool removed = !fs::exists(path_, ec);
  struct stat st {};
  if (::fstat(fd_, &st) != 0) return u;
  rig::JournalContents j;
  try {
    j = rig::read_journal(fmt::format("/proc/self/fd/{}", fd_));
  } catch (const InputError& e) {
    // The writer makes its two header blocks durable before anything else: until they
    // are there, the journal is still being created.
    if (std::size_t(st.st_size) < 2 * rig::kJournalBlockSize && !removed) return u;
    throw InputError(path_.string(), "(journal)", "a burrbench acquisition journal", e.what());
  }
  if (removed) ended_ = true;
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
