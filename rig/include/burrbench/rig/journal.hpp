#pragma once
// Crash-safe acquisition journal: append-only 4096-byte blocks, each with a header CRC,
// holding records that each carry their own CRC. A block is written once and never
// rewritten, so a crash can only tear the block being written; a damaged block costs
// that block alone. docs/rig.md describes the byte layout.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace burrbench::rig {

inline constexpr std::size_t kJournalBlockSize = 4096;

struct JournalSample {
  std::uint16_t device = 0;          // index in the register map
  std::int64_t t_send_ns = 0, t_recv_ns = 0;  // CLOCK_MONOTONIC
  std::int64_t counter = -1;         // device counter, -1 = none
  std::vector<std::uint16_t> regs;
};

struct JournalEvent {
  std::int64_t t_ns = 0;
  int device = -1;                   // -1 = the session
  std::string kind, detail;
};

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

class JournalWriter {
 public:
  // Creates the file (refuses to overwrite one) and makes the header durable.
  JournalWriter(const std::filesystem::path& path, const std::string& header_json);
  ~JournalWriter();
  JournalWriter(const JournalWriter&) = delete;
  JournalWriter& operator=(const JournalWriter&) = delete;

  void append(const JournalSample& s);
  void append(const JournalEvent& e);
  // Writes every buffered record and fdatasync()s. Throws std::runtime_error on any
  // I/O or sync error: the caller stops acquisition (a failed fsync is never retried).
  void sync();
  void finish();  // end marker + sync
  std::uint64_t blocks_written() const { return seq_; }

 private:
  void add_record(std::uint8_t type, const std::vector<std::uint8_t>& payload);
  void seal_block();
  std::filesystem::path path_;
  int fd_ = -1;
  std::uint64_t seq_ = 0;
  std::vector<std::uint8_t> block_;         // block being filled
  std::vector<std::uint8_t> pending_;       // sealed blocks not yet written
};

struct JournalContents {
  std::string header_json;
  std::vector<JournalSample> samples;
  std::vector<JournalEvent> events;
  bool clean_end = false;             // the writer finished normally
  std::size_t blocks = 0;             // whole blocks in the file
  std::size_t corrupt_blocks = 0;     // skipped (header or a record CRC failed)
  std::size_t torn_tail_bytes = 0;    // trailing partial block, ignored
  std::vector<std::string> problems;  // one line per skipped block
};

// Reads a journal without modifying it. InputError if it is not a journal or no intact
// copy of the header survives; damaged blocks are skipped and reported.
JournalContents read_journal(const std::filesystem::path& path);

}  // namespace burrbench::rig
