#pragma once
// Strict reading of a burrbench TOML input (manifest, parameter set, CSV map, rig map,
// protocol, criteria). Every getter names the dotted key path in its InputError
// ("E.toml: recordings[1].registration.rotation: expected ..., got ..."), and unknown
// keys are errors: either list the allowed keys (allow()) or let done() reject every key
// that no getter consumed. Parse with toml_input.hpp first.
//
//   const toml::table t = parse_toml_file(path);
//   TomlView root(t, path.string());
//   const double r = root.positive("radius_mm");
//   for (auto& m : root.tables("moves")) { ...; m.done(); }   // moves[0].x, moves[1].x ...
//   root.done();
#include <toml++/toml.h>

#include <cstdint>
#include <glm/glm.hpp>
#include <initializer_list>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace burrbench::data_schema {

class TomlView {
 public:
  // `path` is the dotted path of `t` in its file ("" for the root); `docs` is the page the
  // unknown-key message points to. Sub-views inherit file and docs.
  TomlView(const toml::table& t, std::string file, std::string path = {},
           std::string docs = "docs/formats.md");

  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  std::string field(std::string_view key) const;  // "path.key", or "key" at the root
  bool has(std::string_view key) const { return t_->contains(key); }
  std::vector<std::string> keys() const;

  // InputError(file, field(key), expected, got): for checks the getters cannot express.
  [[noreturn]] void fail(std::string_view key, const std::string& expected,
                         const std::string& got = {}) const;

  // Required getters: a missing key gives "expected X, got missing", a wrong type
  // "expected X, got a string" (the TOML kind), a NaN/inf "expected a finite number, got inf".
  std::string str(std::string_view key) const;
  std::string str_or(std::string_view key, std::string def) const;
  std::optional<std::string> opt_str(std::string_view key) const;
  double num(std::string_view key) const;  // integer or float, finite
  double num_or(std::string_view key, double def) const;
  std::optional<double> opt_num(std::string_view key) const;
  double num_or_inf(std::string_view key) const;    // also +inf (TOML inf or the string "inf")
  double positive(std::string_view key) const;      // finite, > 0
  double non_negative(std::string_view key) const;  // finite, ≥ 0
  std::int64_t integer(std::string_view key) const;
  // In [lo, hi]; the message names the range.
  std::int64_t integer(std::string_view key, std::int64_t lo, std::int64_t hi) const;
  std::int64_t integer_or(std::string_view key, std::int64_t lo, std::int64_t hi,
                          std::int64_t def) const;
  bool boolean(std::string_view key) const;
  std::optional<bool> opt_boolean(std::string_view key) const;

  // Arrays: exactly `count` finite numbers; rows × cols numbers (row-major); at most 10000
  // [x, y, z] points; strings; 1 to max_count integers in [lo, hi]. Elements are named
  // key[i] (and key[i][j]) in messages.
  std::vector<double> numbers(std::string_view key, std::size_t count) const;
  glm::dvec3 vec3(std::string_view key) const;
  glm::dmat3 mat3_rows(std::string_view key) const;  // [[r0],[r1],[r2]] → glm (column-major)
  std::vector<double> number_rows(std::string_view key, std::size_t rows, std::size_t cols) const;
  std::vector<glm::dvec3> points(std::string_view key) const;
  std::vector<std::string> strings(std::string_view key) const;
  std::vector<std::int64_t> integers(std::string_view key, std::int64_t lo, std::int64_t hi,
                                     std::size_t max_count) const;

  TomlView table(std::string_view key) const;
  std::optional<TomlView> opt_table(std::string_view key) const;
  // An array of tables, viewed as key[0], key[1] ...; absent → empty.
  std::vector<TomlView> tables(std::string_view key) const;

  // The raw node (nullptr when absent), consumed: for values of more than one shape.
  const toml::node* node(std::string_view key) const;

  // InputError on the first key of this table that is not in `allowed`.
  void allow(std::initializer_list<std::string_view> allowed) const;
  // Mark a key as consumed without reading it through this view.
  void use(std::string_view key) const { used_.emplace(key); }
  // InputError on the first key that no getter consumed.
  void done() const;

 private:
  const toml::node* get(std::string_view key, const std::string& expected) const;
  double number_node(const toml::node& n, const std::string& field, bool allow_inf) const;
  [[noreturn]] void unknown(std::string_view key) const;

  const toml::table* t_;
  std::string file_, path_, docs_;
  // Consumption is bookkeeping about the reading, not the data: getters stay const.
  mutable std::set<std::string, std::less<>> used_;
};

}  // namespace burrbench::data_schema
