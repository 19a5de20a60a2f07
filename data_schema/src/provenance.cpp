#include "burrbench/data_schema/provenance.hpp"

#include <openssl/evp.h>

#include <array>
#include <chrono>
#include <ctime>
#include <fstream>
#include <memory>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/version.hpp"

namespace burrbench {

namespace {
struct Digest {
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx{EVP_MD_CTX_new(), &EVP_MD_CTX_free};
  Digest() { EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr); }
  void add(const void* d, std::size_t n) { EVP_DigestUpdate(ctx.get(), d, n); }
  std::string hex() {
    std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
    unsigned int len = 0;
    EVP_DigestFinal_ex(ctx.get(), md.data(), &len);
    std::string out;
    for (unsigned i = 0; i < len; ++i) out += fmt::format("{:02x}", md[i]);
    return out;
  }
};

std::string& invocation_storage() {
  static std::string s;
  return s;
}

std::string shell_quote(const std::string& a) {
  if (!a.empty() && a.find_first_of(" \t\n'\"\\$`*?[]{}();&|<>") == std::string::npos) return a;
  std::string q = "'";
  for (char c : a) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}
}  // namespace

std::string sha256_bytes(const void* data, std::size_t size) {
  Digest d;
  d.add(data, size);
  return d.hex();
}

std::string sha256_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "<file>", "a readable file");
  Digest d;
  std::array<char, 1 << 16> buf{};
  while (in) {
    in.read(buf.data(), buf.size());
    d.add(buf.data(), static_cast<std::size_t>(in.gcount()));
  }
  return d.hex();
}

std::string sha256_before_read(const std::filesystem::path& path) {
  try {
    return sha256_file(path);
  } catch (const InputError&) {
    return "";
  }
}

void set_invocation(int argc, const char* const* argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) {
    if (i) s += ' ';
    s += shell_quote(argv[i]);
  }
  invocation_storage() = s;
}

const std::string& invocation() { return invocation_storage(); }

Provenance make_provenance(const std::vector<std::filesystem::path>& inputs) {
  std::vector<InputFile> hashed;
  for (const auto& f : inputs) hashed.push_back({f.string(), sha256_file(f)});
  return make_provenance_hashed(std::move(hashed));
}

Provenance make_provenance_hashed(std::vector<InputFile> hashed_inputs) {
  Provenance p;
  p.software_version = software_version();
  p.command_line = invocation();
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  p.created_utc = fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", tm.tm_year + 1900,
                              tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
  p.inputs = std::move(hashed_inputs);
  return p;
}

void check_unchanged(const std::vector<InputFile>& inputs, const std::string& command) {
  for (const auto& f : inputs) {
    std::error_code ec;
    const bool gone = !std::filesystem::exists(f.path, ec);
    const std::string now = gone ? "" : sha256_file(f.path);
    if (now != f.sha256)
      throw InputError(f.path, "file",
                       fmt::format("unchanged while {} ran (SHA-256 {}… when read): its results would not describe "
                                   "the file on disk; nothing was written, run it again",
                                   command, f.sha256.substr(0, 12)),
                       gone ? "removed" : fmt::format("changed (now {}…)", now.substr(0, 12)));
  }
}

}  // namespace burrbench
