#include "burrbench/data_schema/json_input.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/nesting.hpp"

namespace burrbench::data_schema {

using nlohmann::json;

nlohmann::json read_json_file(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(file, "<file>", "an existing regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxJsonBytes) throw InputError(file, "<file>", fmt::format("a JSON file of at most {} MiB", kMaxJsonBytes >> 20), fmt::format("{} bytes", size));
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  check_json_nesting(text, file);  // before nlohmann::json recurses
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file, fmt::format("byte {}", e.byte), "valid JSON", e.what());
  } catch (const nlohmann::json::exception& e) {
    // e.g. out_of_range 406: a number beyond double's range ("1e999"); found by fuzz_fit_json
    throw InputError(file, "<file>", "valid JSON with numbers in double's range", e.what());
  }
}

JsonView::JsonView(const json& j, std::string file, std::string path)
    : j_(&j), file_(std::move(file)), path_(std::move(path)) {
  if (!j.is_object())
    throw InputError(file_, path_.empty() ? "<root>" : path_, "a JSON object", j.type_name());
}

JsonView::JsonView(const json& j, std::string file, std::string path,
                   std::initializer_list<std::string> known)
    : JsonView(j, std::move(file), std::move(path)) {
  const std::set<std::string> allowed(known);
  for (auto it = j_->begin(); it != j_->end(); ++it)
    if (!allowed.count(it.key()))
      throw InputError(file_, field(it.key()), "a known key (see docs/formats.md)", "unknown key");
  used_ = allowed;  // every member is known: done() has nothing left to refuse
}

const json& JsonView::get(const std::string& k) {
  used_.insert(k);
  const auto it = j_->find(k);
  if (it == j_->end()) throw InputError(file_, field(k), "a value", "missing");
  return *it;
}

std::string JsonView::str(const std::string& k) {
  const json& v = get(k);
  if (!v.is_string()) throw InputError(file_, field(k), "a string", v.type_name());
  return v.get<std::string>();
}

std::string JsonView::str_or(const std::string& k, const std::string& fallback) {
  return has(k) ? str(k) : fallback;
}

double JsonView::finite(const std::string& k) {
  const json& v = get(k);
  if (!v.is_number()) throw InputError(file_, field(k), "a number", v.type_name());
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InputError(file_, field(k), "a finite number", v.dump());
  return d;
}

double JsonView::number(const std::string& k) {
  const json& v = get(k);
  if (v.is_null()) return std::nan("");
  if (v.is_number()) return v.get<double>();
  if (v == "inf") return INFINITY;
  if (v == "-inf") return -INFINITY;
  throw InputError(file_, field(k), "a number, null or \"inf\"", v.type_name());
}

double JsonView::opt_number(const std::string& k) { return has(k) ? number(k) : std::nan(""); }

std::uint64_t JsonView::count(const std::string& k) {
  const json& v = get(k);
  if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0))
    throw InputError(file_, field(k), "a non-negative integer", v.is_number() ? v.dump() : v.type_name());
  return v.get<std::uint64_t>();
}

bool JsonView::boolean(const std::string& k) {
  const json& v = get(k);
  if (!v.is_boolean()) throw InputError(file_, field(k), "true or false", v.type_name());
  return v.get<bool>();
}

const json& JsonView::array(const std::string& k) {
  const json& v = get(k);
  if (!v.is_array()) throw InputError(file_, field(k), "an array", v.type_name());
  return v;
}

const json& JsonView::array_or_empty(const std::string& k) {
  static const json empty = json::array();
  return has(k) ? array(k) : empty;
}

const json& JsonView::object(const std::string& k) {
  const json& v = get(k);
  if (!v.is_object()) throw InputError(file_, field(k), "an object", v.type_name());
  return v;
}

void JsonView::done() const {
  for (auto it = j_->begin(); it != j_->end(); ++it)
    if (!used_.count(it.key()))
      throw InputError(file_, field(it.key()), "a known key (see docs/formats.md)", "unknown key");
}

json json_number(double x) {
  if (std::isnan(x)) return nullptr;
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  return x;
}

json provenance_json(const Provenance& p) {
  json inputs = json::array();
  for (const auto& f : p.inputs) inputs.push_back({{"path", f.path}, {"sha256", f.sha256}});
  return {{"software_version", p.software_version},
          {"command_line", p.command_line},
          {"created_utc", p.created_utc},
          {"inputs", inputs}};
}

Provenance read_provenance(JsonView v) {
  Provenance p;
  p.software_version = v.str("software_version");
  p.command_line = v.str("command_line");
  p.created_utc = v.str("created_utc");
  const json& inputs = v.array("inputs");
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    JsonView f(inputs[i], v.file(), v.field(fmt::format("inputs[{}]", i)), {"path", "sha256"});
    p.inputs.push_back({f.str("path"), f.str("sha256")});
  }
  v.done();
  return p;
}

}  // namespace burrbench::data_schema
