#pragma once
// Shared bits of the test_formats_* tests: a temporary folder (temp_dir.hpp), file bytes, and an
// assertion that a call throws InputError whose message contains given fragments.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <sstream>
#include <string>

#include "burrbench/data_schema/error.hpp"
#include "temp_dir.hpp"

namespace burrbench::test {

inline std::string file_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

// Deterministic corruptions of a file's bytes, each written to `corrupt` and handed to
// `read`: `bytes` bytes overwritten, or (with truncate_odd) every other one truncated.
// Only an InputError naming the corrupt file may come out; returns how many were rejected.
inline int count_rejected_corruptions(const std::string& base, const std::filesystem::path& corrupt, int n,
                                      std::uint64_t seed, int bytes, bool truncate_odd,
                                      const std::function<void(const std::filesystem::path&)>& read) {
  std::uint64_t state = seed;
  auto next = [&] { return state = state * 6364136223846793005ull + 1442695040888963407ull, state >> 33; };
  const std::string name = corrupt.filename().string() + ": ";
  int rejected = 0;
  for (int i = 0; i < n; ++i) {
    std::string t = base;
    if (truncate_odd && i % 2) t.resize(next() % t.size());
    else for (int k = 0; k < bytes; ++k) t[next() % t.size()] = char(next() % 256);
    write_text(corrupt, t);
    try {
      read(corrupt);
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      ++rejected;
    }
  }
  return rejected;
}

// Runs f; expects an InputError whose message contains every fragment.
inline void expect_input_error(const std::function<void()>& f, std::initializer_list<std::string> fragments) {
  try {
    f();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    for (const auto& frag : fragments) EXPECT_NE(msg.find(frag), std::string::npos) << "message: " << msg << "\nmissing: " << frag;
    return;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got another exception: " << e.what();
    return;
  }
  ADD_FAILURE() << "expected InputError, nothing thrown";
}

// Expects a failed read that leaves the input's bytes unchanged.
inline void expect_rejected_unchanged(const std::filesystem::path& p, const std::function<void()>& read,
                                      std::initializer_list<std::string> fragments) {
  const std::string before = file_bytes(p);
  expect_input_error(read, fragments);
  EXPECT_EQ(before, file_bytes(p)) << "input file modified: " << p;
}

}  // namespace burrbench::test
