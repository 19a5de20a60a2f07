#pragma once
// JSON of ours, one way for every JSON format (fit, analysis, metrics, truth):
// - read_json_file: an existing regular file of at most 256 MiB, nested at most
//   kMaxNesting deep (checked before nlohmann recurses), valid JSON;
// - JsonView: the strict object reader (unknown keys refused, types checked, errors name
//   the file and the JSON path);
// - json_number / provenance_json and read_provenance: the encodings shared by the writers.
// InputError naming the file (and the byte, for a syntax error) otherwise.
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema {

// A JSON file's size, checked before it is read: parsed, a file takes about 25 times its
// size in memory (a 100 MB fit.json took 2.6 GB, issue 59 D11). The largest fit.json of
// a study is a few MB.
inline constexpr std::uintmax_t kMaxJsonBytes = 32u << 20;

nlohmann::json read_json_file(const std::filesystem::path& path);

// Strict view of one JSON object. With a list of known keys, any other key is refused at
// once; without one, done() refuses every key that was never read.
class JsonView {
 public:
  JsonView(const nlohmann::json& j, std::string file, std::string path);
  JsonView(const nlohmann::json& j, std::string file, std::string path,
           std::initializer_list<std::string> known);
  // The JSON path of a member, as errors name it ("recordings[2].role").
  std::string field(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  const std::string& file() const { return file_; }
  bool has(const std::string& k) const { return j_->contains(k); }
  const nlohmann::json& get(const std::string& k);  // present, any type
  std::string str(const std::string& k);
  std::string str_or(const std::string& k, const std::string& fallback);
  double finite(const std::string& k);  // a finite number
  // A number, or the encodings of non-finite ones that json_number writes: null (NaN),
  // "inf", "-inf".
  double number(const std::string& k);
  double opt_number(const std::string& k);  // number(k), NaN when absent
  std::uint64_t count(const std::string& k);  // a non-negative integer
  bool boolean(const std::string& k);
  const nlohmann::json& array(const std::string& k);
  const nlohmann::json& array_or_empty(const std::string& k);
  const nlohmann::json& object(const std::string& k);
  JsonView sub(const std::string& k) { return JsonView(get(k), file_, field(k)); }
  JsonView sub(const std::string& k, std::initializer_list<std::string> known) {
    return JsonView(get(k), file_, field(k), known);
  }
  void done() const;

 private:
  const nlohmann::json* j_;
  std::string file_, path_;
  std::set<std::string> used_;
};

// A double as JSON: NaN → null, ±inf → "inf"/"-inf" (JSON has neither).
nlohmann::json json_number(double x);
// Provenance as every JSON format stores it: {software_version, command_line,
// created_utc, inputs: [{path, sha256}]}.
nlohmann::json provenance_json(const Provenance& p);
Provenance read_provenance(JsonView v);

}  // namespace burrbench::data_schema
