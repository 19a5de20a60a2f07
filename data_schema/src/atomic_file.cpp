#include "burrbench/data_schema/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdint>
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
enum class Kind { kFile, kFolder, kTree };  // unlink; rmdir if empty; unlink its files, rmdir
struct Slot {
  std::atomic<bool> used{false};
  Kind kind = Kind::kFile;
  char path[4096];
};
std::array<Slot, kSlots> g_slots;

// Unlinks the files of a (flat) staging folder, then the folder. Only async-signal-safe
// calls: getdents64 through syscall() instead of opendir/readdir, which may allocate.
void remove_tree_in_handler(const char* path) {
  const int fd = ::open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  struct Dirent64 {
    std::uint64_t ino;
    std::int64_t off;
    unsigned short reclen;
    unsigned char type;
    char name[1];
  };
  alignas(8) static char buf[16384];
  for (int pass = 0; pass < 16; ++pass) {  // unlinking while listing may hide entries: list again
    bool removed = false;
    ::lseek(fd, 0, SEEK_SET);
    for (long n; (n = ::syscall(SYS_getdents64, fd, buf, sizeof buf)) > 0;)
      for (long at = 0; at < n;) {
        const auto* d = reinterpret_cast<const Dirent64*>(buf + at);
        at += d->reclen;
        const char* nm = buf + (at - d->reclen) + offsetof(Dirent64, name);
        if (nm[0] == '.' && (nm[1] == 0 || (nm[1] == '.' && nm[2] == 0))) continue;
        removed |= ::unlinkat(fd, nm, 0) == 0;
      }
    if (!removed) break;
  }
  ::close(fd);
  ::rmdir(path);
}

void on_signal(int sig) {
  for (auto& s : g_slots)
    if (s.used.load() && s.kind == Kind::kFile) ::unlink(s.path);
  for (auto& s : g_slots)  // staging folders, then the (now empty) output folders
    if (s.used.load() && s.kind == Kind::kTree) remove_tree_in_handler(s.path);
  for (auto& s : g_slots)
    if (s.used.load() && s.kind == Kind::kFolder) ::rmdir(s.path);
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

int register_slot(const std::filesystem::path& tmp, Kind kind) {
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
    g_slots[std::size_t(i)].kind = kind;
    if (g_slots[std::size_t(i)].used.compare_exchange_strong(expected, true)) return i;
  }
  return -1;
}

}  // namespace

int register_temporary(const std::filesystem::path& tmp, bool folder) {
  return register_slot(tmp, folder ? Kind::kFolder : Kind::kFile);
}

int register_temporary_tree(const std::filesystem::path& folder) { return register_slot(folder, Kind::kTree); }

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
  sync_folder(target.parent_path());  // the rename is durable once its folder is
}

void sync_folder(const std::filesystem::path& dir) {
  const std::filesystem::path d = dir.empty() ? std::filesystem::path(".") : dir;
  if (const int fd = ::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
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
