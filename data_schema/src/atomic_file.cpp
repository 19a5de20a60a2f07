#include "burrbench/data_schema/atomic_file.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <signal.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <stdexcept>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema {
namespace {

// Temporaries to unlink on SIGINT/SIGTERM. The handler may only call async-signal-safe
// functions, so the paths live in fixed buffers claimed with an atomic flag.
constexpr int kSlots = 64;
struct Slot {
  std::atomic<bool> used{false};
  bool folder = false;  // rmdir (only if empty) instead of unlink
  char path[4096];
};
std::array<Slot, kSlots> g_slots;

void on_signal(int sig) {
  for (auto& s : g_slots)
    if (s.used.load() && !s.folder) ::unlink(s.path);
  for (auto& s : g_slots)  // folders after the files in them
    if (s.used.load() && s.folder) ::rmdir(s.path);
  static const char msg[] = "\nburrbench: interrupted; unfinished files removed\n";
  [[maybe_unused]] const auto n = ::write(2, msg, sizeof msg - 1);
  // Then die of the signal as we would have (exit status 128 + sig for the shell).
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

void install_handlers_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    // A verb with its own handler (acquire stops its session on Ctrl-C) keeps it.
    for (int sig : {SIGINT, SIGTERM}) {
      struct sigaction old {};
      sigaction(sig, nullptr, &old);
      if (old.sa_handler != SIG_DFL) continue;
      struct sigaction sa {};
      sa.sa_handler = on_signal;
      sigemptyset(&sa.sa_mask);
      sigaction(sig, &sa, nullptr);
    }
    ::signal(SIGXFSZ, SIG_IGN);  // a file-size limit is a write error, not a kill
  });
}

std::atomic<unsigned> g_counter{0};

}  // namespace

int register_temporary(const std::filesystem::path& tmp, bool folder) {
  install_handlers_once();
  const std::string p = tmp.string();
  if (p.size() >= sizeof(Slot::path)) return -1;
  for (int i = 0; i < kSlots; ++i) {
    bool expected = false;
    // Claim, fill, then publish: the handler reads only published paths.
    static std::mutex m;
    std::lock_guard lk(m);
    if (g_slots[std::size_t(i)].used.load()) continue;
    std::memcpy(g_slots[std::size_t(i)].path, p.c_str(), p.size() + 1);
    g_slots[std::size_t(i)].folder = folder;
    if (g_slots[std::size_t(i)].used.compare_exchange_strong(expected, true)) return i;
  }
  return -1;
}

void unregister_temporary(int slot) {
  if (slot >= 0 && slot < kSlots) g_slots[std::size_t(slot)].used = false;
}

AtomicFile::AtomicFile(std::filesystem::path target) : target_(std::move(target)) {
  tmp_ = target_.string() + fmt::format(".tmp-{}-{}", ::getpid(), g_counter++);
  slot_ = register_temporary(tmp_);
  fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0) fail("cannot create a file beside it", errno);
  buf_.reserve(1 << 20);
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!tmp_.empty()) ::unlink(tmp_.c_str());
  unregister_temporary(slot_);
}

void AtomicFile::fail(const std::string& what, int err) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(tmp_.c_str());
  unregister_temporary(slot_);
  slot_ = -1;
  tmp_.clear();
  throw std::runtime_error(fmt::format("{}: {} ({}); nothing was written there", target_.string(), what,
                                       std::strerror(err)));
}

void AtomicFile::write(std::string_view bytes) {
  if (tmp_.empty()) throw std::logic_error("AtomicFile used after commit or failure");
  buf_.append(bytes);
  if (buf_.size() >= (1u << 20)) flush();
}

void AtomicFile::flush() {
  const char* p = buf_.data();
  std::size_t left = buf_.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail("write failed", n < 0 ? errno : EIO);
    p += n;
    left -= std::size_t(n);
  }
  buf_.clear();
}

void AtomicFile::commit() {
  flush();
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("close failed", errno);
  const auto tmp = tmp_;
  tmp_.clear();  // publish_temporary removes it on failure
  publish_temporary(tmp, target_);
  unregister_temporary(slot_);
  slot_ = -1;
}

void publish_temporary(const std::filesystem::path& tmp, const std::filesystem::path& target) {
  const auto failed = [&](const char* what, int err) {
    ::unlink(tmp.c_str());
    throw std::runtime_error(fmt::format("{}: {} ({}); nothing was written there", target.string(), what,
                                         std::strerror(err)));
  };
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) failed("cannot reopen the finished file", errno);
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    failed("fsync failed", err);
  }
  ::close(fd);
  if (::rename(tmp.c_str(), target.c_str()) != 0) failed("cannot rename the finished file onto it", errno);
  // The rename is durable once the folder is synced (best effort: some filesystems refuse).
  const auto dir = target.parent_path().empty() ? std::filesystem::path(".") : target.parent_path();
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

OutputFolder::OutputFolder(const std::filesystem::path& path, const std::string& option) : path_(path) {
  std::error_code ec;
  if (std::filesystem::exists(path_, ec)) {
    if (!std::filesystem::is_directory(path_, ec))
      throw InputError(path_.string(), option, "a directory (or a path to create one)", "an existing file");
  } else {
    std::filesystem::create_directories(path_, ec);
    if (ec) throw InputError(path_.string(), option, "a directory that can be created", ec.message());
    created_ = true;
    slot_ = register_temporary(path_, true);
  }
  lock_fd_ = ::open(path_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (lock_fd_ >= 0 && ::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    created_ = false;  // not ours to remove
    unregister_temporary(slot_);
    slot_ = -1;
    throw InputError(path_.string(), option, "a folder no other burrbench command is writing",
                     "in use by another run");
  }
}

OutputFolder::~OutputFolder() {
  unregister_temporary(slot_);
  std::error_code ec;
  if (created_ && std::filesystem::is_empty(path_, ec)) std::filesystem::remove(path_, ec);
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

void OutputFolder::keep() {
  created_ = false;
  unregister_temporary(slot_);
  slot_ = -1;
}

void copy_file_atomic(const std::filesystem::path& from, const std::filesystem::path& target) {
  const int fd = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error(fmt::format("{}: cannot read it to copy ({})", from.string(), std::strerror(errno)));
  AtomicFile out(target);
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      throw std::runtime_error(fmt::format("{}: cannot read it to copy ({})", from.string(), std::strerror(err)));
    }
    if (n == 0) break;
    out.write(std::string_view(buf, std::size_t(n)));
  }
  ::close(fd);
  out.commit();
}

void write_file_atomic(const std::filesystem::path& target, std::string_view bytes) {
  AtomicFile f(target);
  f.write(bytes);
  f.commit();
}

}  // namespace burrbench::data_schema
