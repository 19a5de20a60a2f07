#include "burrbench/rig/journal.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::rig {
namespace {

constexpr std::uint32_t kMagic = 0x314a4242;  // "BBJ1" little-endian
constexpr std::size_t kBlockHeader = 20;      // magic u32, seq u64, used u32, crc u32
constexpr std::size_t kRecordHeader = 8;      // len u16, type u8, pad u8, crc u32
constexpr std::size_t kChunk = 3000;          // header JSON bytes per record
enum RecordType : std::uint8_t { kHeaderChunk = 1, kSample = 2, kEvent = 3, kEnd = 4 };

const std::array<std::uint32_t, 256>& crc_table() {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  return table;
}

template <class T>
void put(std::vector<std::uint8_t>& b, T v) {
  const std::size_t at = b.size();
  b.resize(at + sizeof(T));
  std::memcpy(b.data() + at, &v, sizeof(T));  // little-endian hosts only (x86-64, aarch64)
}
template <class T>
T get(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

}  // namespace

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  const auto& t = crc_table();
  const auto* p = static_cast<const std::uint8_t*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = t[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

JournalWriter::JournalWriter(const std::filesystem::path& path, const std::string& header_json)
    : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(path.string(), "(journal)", "a new file (recover or remove an old journal first)",
                     std::strerror(errno));
  // Two copies of the header in separate blocks: one flipped byte cannot make the
  // journal unrecoverable.
  for (int copy = 0; copy < 2; ++copy) {
    const std::uint32_t total = static_cast<std::uint32_t>((header_json.size() + kChunk - 1) / kChunk);
    for (std::uint32_t i = 0; i < total; ++i) {
      std::vector<std::uint8_t> p;
      put<std::uint32_t>(p, i);
      put<std::uint32_t>(p, total);
      const auto part = header_json.substr(i * kChunk, kChunk);
      p.insert(p.end(), part.begin(), part.end());
      add_record(kHeaderChunk, p);
    }
    seal_block();
  }
  sync();
}

JournalWriter::~JournalWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void JournalWriter::add_record(std::uint8_t type, const std::vector<std::uint8_t>& payload) {
  BURRBENCH_CHECK(payload.size() + kRecordHeader + kBlockHeader <= kJournalBlockSize, "record fits a block");
  if (block_.empty()) block_.resize(kBlockHeader);
  if (block_.size() + kRecordHeader + payload.size() > kJournalBlockSize) {
    seal_block();
    block_.resize(kBlockHeader);
  }
  put<std::uint16_t>(block_, static_cast<std::uint16_t>(payload.size()));
  put<std::uint8_t>(block_, type);
  put<std::uint8_t>(block_, 0);
  std::uint32_t c = crc32(&type, 1);
  c = crc32(payload.data(), payload.size(), c);
  put<std::uint32_t>(block_, c);
  block_.insert(block_.end(), payload.begin(), payload.end());
}

void JournalWriter::seal_block() {
  if (block_.size() <= kBlockHeader) return;
  const auto used = static_cast<std::uint32_t>(block_.size() - kBlockHeader);
  block_.resize(kJournalBlockSize, 0);
  std::uint8_t* h = block_.data();
  std::memcpy(h, &kMagic, 4);
  std::memcpy(h + 4, &seq_, 8);
  std::memcpy(h + 12, &used, 4);
  const std::uint32_t c = crc32(h, 16);
  std::memcpy(h + 16, &c, 4);
  pending_.insert(pending_.end(), block_.begin(), block_.end());
  block_.clear();
  ++seq_;
}

void JournalWriter::append(const JournalSample& s) {
  std::vector<std::uint8_t> p;
  p.reserve(28 + 2 * s.regs.size());
  put<std::uint16_t>(p, s.device);
  put<std::uint16_t>(p, static_cast<std::uint16_t>(s.regs.size()));
  put<std::int64_t>(p, s.t_send_ns);
  put<std::int64_t>(p, s.t_recv_ns);
  put<std::int64_t>(p, s.counter);
  for (auto r : s.regs) put<std::uint16_t>(p, r);
  add_record(kSample, p);
}

void JournalWriter::append(const JournalEvent& e) {
  std::vector<std::uint8_t> p;
  const std::string kind = e.kind.substr(0, 64);
  const std::string detail = e.detail.substr(0, 2000);
  put<std::int64_t>(p, e.t_ns);
  put<std::int16_t>(p, static_cast<std::int16_t>(e.device));
  put<std::uint16_t>(p, static_cast<std::uint16_t>(kind.size()));
  p.insert(p.end(), kind.begin(), kind.end());
  p.insert(p.end(), detail.begin(), detail.end());
  add_record(kEvent, p);
}

void JournalWriter::sync() {
  seal_block();  // a partial block is padded and written now, never rewritten later
  std::size_t off = 0;
  while (off < pending_.size()) {
    const ssize_t n = ::write(fd_, pending_.data() + off, pending_.size() - off);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(fmt::format("journal {}: write failed: {}", path_.string(), std::strerror(errno)));
    }
    off += static_cast<std::size_t>(n);
  }
  pending_.clear();
  if (::fdatasync(fd_) != 0)
    throw std::runtime_error(fmt::format("journal {}: fdatasync failed: {} — acquisition stopped, data after the last sync may be lost",
                                         path_.string(), std::strerror(errno)));
}

void JournalWriter::finish() {
  add_record(kEnd, {});
  sync();
}

JournalContents read_journal(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "(file)", "a readable journal", "cannot open");
  JournalContents out;
  std::vector<std::string> header_parts;
  std::uint32_t header_total = 0;
  bool header_done = false;
  std::vector<std::uint8_t> block(kJournalBlockSize);
  for (std::size_t index = 0;; ++index) {
    in.read(reinterpret_cast<char*>(block.data()), static_cast<std::streamsize>(kJournalBlockSize));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0) break;
    if (got < kJournalBlockSize) {
      out.torn_tail_bytes = got;
      out.problems.push_back(fmt::format("torn tail: {} bytes after block {} ignored", got, index));
      break;
    }
    ++out.blocks;
    const std::uint8_t* h = block.data();
    const auto used = get<std::uint32_t>(h + 12);
    if (get<std::uint32_t>(h) != kMagic || get<std::uint32_t>(h + 16) != crc32(h, 16) ||
        used > kJournalBlockSize - kBlockHeader) {
      if (index == 0 && get<std::uint32_t>(h) != kMagic && get<std::uint32_t>(h + 16) != crc32(h, 16))
        out.problems.push_back("block 0: not a burrbench journal block");
      else
        out.problems.push_back(fmt::format("block {}: header damaged, skipped", index));
      ++out.corrupt_blocks;
      continue;
    }
    if (get<std::uint64_t>(h + 4) != index) {
      out.problems.push_back(fmt::format("block {}: sequence {} out of place, skipped", index, get<std::uint64_t>(h + 4)));
      ++out.corrupt_blocks;
      continue;
    }
    // Parse into temporaries: the block counts only if every record in it is intact.
    std::vector<JournalSample> samples;
    std::vector<JournalEvent> events;
    std::vector<std::pair<std::uint32_t, std::string>> chunks;
    std::uint32_t chunk_total = 0;
    bool end = false, bad = false;
    std::size_t pos = kBlockHeader;
    const std::size_t stop = kBlockHeader + used;
    while (pos < stop && !bad) {
      if (pos + kRecordHeader > stop) { bad = true; break; }
      const auto len = get<std::uint16_t>(h + pos);
      const auto type = h[pos + 2];
      const auto crc = get<std::uint32_t>(h + pos + 4);
      const std::uint8_t* p = h + pos + kRecordHeader;
      if (pos + kRecordHeader + len > stop || crc32(p, len, crc32(&type, 1)) != crc) { bad = true; break; }
      switch (type) {
        case kHeaderChunk: {
          if (len < 8) { bad = true; break; }
          chunk_total = get<std::uint32_t>(p + 4);
          chunks.emplace_back(get<std::uint32_t>(p), std::string(reinterpret_cast<const char*>(p + 8), len - 8u));
          break;
        }
        case kSample: {
          if (len < 28) { bad = true; break; }
          JournalSample s;
          s.device = get<std::uint16_t>(p);
          const auto n = get<std::uint16_t>(p + 2);
          if (len != 28u + 2u * n) { bad = true; break; }
          s.t_send_ns = get<std::int64_t>(p + 4);
          s.t_recv_ns = get<std::int64_t>(p + 12);
          s.counter = get<std::int64_t>(p + 20);
          s.regs.resize(n);
          for (std::size_t i = 0; i < n; ++i) s.regs[i] = get<std::uint16_t>(p + 28 + 2 * i);
          samples.push_back(std::move(s));
          break;
        }
        case kEvent: {
          if (len < 12) { bad = true; break; }
          JournalEvent e;
          e.t_ns = get<std::int64_t>(p);
          e.device = get<std::int16_t>(p + 8);
          const auto klen = get<std::uint16_t>(p + 10);
          if (12u + klen > len) { bad = true; break; }
          e.kind.assign(reinterpret_cast<const char*>(p + 12), klen);
          e.detail.assign(reinterpret_cast<const char*>(p + 12 + klen), len - 12u - klen);
          events.push_back(std::move(e));
          break;
        }
        case kEnd: end = true; break;
        default: bad = true;
      }
      pos += kRecordHeader + len;
    }
    if (bad) {
      out.problems.push_back(fmt::format("block {}: record CRC or layout damaged, block skipped", index));
      ++out.corrupt_blocks;
      continue;
    }
    for (auto& [i, part] : chunks) {
      if (header_done) break;
      if (i == 0) { header_parts.clear(); header_total = chunk_total; }
      if (i == header_parts.size() && chunk_total == header_total) header_parts.push_back(part);
      if (header_total > 0 && header_parts.size() == header_total) {
        for (auto& s : header_parts) out.header_json += s;
        header_done = true;
      }
    }
    for (auto& s : samples) out.samples.push_back(std::move(s));
    for (auto& e : events) out.events.push_back(std::move(e));
    out.clean_end = out.clean_end || end;
  }
  if (!header_done)
    throw InputError(path.string(), "header", "a burrbench acquisition journal with an intact header block",
                     out.blocks == 0 ? "no whole block" : "header damaged in both copies");
  return out;
}

}  // namespace burrbench::rig
