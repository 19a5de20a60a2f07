#include "burrbench/data_schema/toml_view.hpp"

#include <fmt/format.h>

#include <cmath>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema {

namespace {

std::string kind(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a float";
    case toml::node_type::boolean:
      return "a boolean";
    default:
      return "a date/time";
  }
}

std::string range(std::int64_t lo, std::int64_t hi) {
  return fmt::format("an integer in [{}, {}]", lo, hi);
}

}  // namespace

TomlView::TomlView(const toml::table& t, std::string file, std::string path, std::string docs)
    : t_(&t), file_(std::move(file)), path_(std::move(path)), docs_(std::move(docs)) {}

std::string TomlView::field(std::string_view key) const {
  return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
}

std::vector<std::string> TomlView::keys() const {
  std::vector<std::string> k;
  for (const auto& [key, node] : *t_) k.emplace_back(key.str());
  return k;
}

void TomlView::fail(std::string_view key, const std::string& expected,
                    const std::string& got) const {
  throw InputError(file_, field(key), expected, got);
}

const toml::node* TomlView::get(std::string_view key, const std::string& expected) const {
  used_.emplace(key);
  const toml::node* n = t_->get(key);
  if (!n) fail(key, expected, "missing");
  return n;
}

double TomlView::number_node(const toml::node& n, const std::string& f, bool allow_inf) const {
  double v = 0;
  if (auto i = n.as_integer())
    v = double(i->get());
  else if (auto d = n.as_floating_point())
    v = d->get();
  else if (auto s = n.as_string(); s && allow_inf && s->get() == "inf")
    v = INFINITY;
  else
    throw InputError(file_, f, allow_inf ? "a number or \"inf\"" : "a number", kind(n));
  if (std::isnan(v) || (std::isinf(v) && !(allow_inf && v > 0)))
    throw InputError(file_, f, allow_inf ? "a finite number or +inf" : "a finite number",
                     fmt::format("{}", v));
  return v;
}

std::string TomlView::str(std::string_view key) const {
  const toml::node* n = get(key, "a string");
  if (auto s = n->as_string()) return s->get();
  fail(key, "a string", kind(*n));
}

std::string TomlView::str_or(std::string_view key, std::string def) const {
  used_.emplace(key);
  return has(key) ? str(key) : def;
}

std::optional<std::string> TomlView::opt_str(std::string_view key) const {
  used_.emplace(key);
  if (!has(key)) return std::nullopt;
  return str(key);
}

double TomlView::num(std::string_view key) const {
  return number_node(*get(key, "a number"), field(key), false);
}

double TomlView::num_or(std::string_view key, double def) const {
  used_.emplace(key);
  return has(key) ? num(key) : def;
}

std::optional<double> TomlView::opt_num(std::string_view key) const {
  used_.emplace(key);
  if (!has(key)) return std::nullopt;
  return num(key);
}

double TomlView::num_or_inf(std::string_view key) const {
  return number_node(*get(key, "a number or \"inf\""), field(key), true);
}

double TomlView::positive(std::string_view key) const {
  const double v = number_node(*get(key, "a number > 0"), field(key), false);
  if (!(v > 0)) fail(key, "a number > 0", fmt::format("{}", v));
  return v;
}

double TomlView::non_negative(std::string_view key) const {
  const double v = number_node(*get(key, "a number ≥ 0"), field(key), false);
  if (v < 0) fail(key, "a number ≥ 0", fmt::format("{}", v));
  return v;
}

std::int64_t TomlView::integer(std::string_view key) const {
  const toml::node* n = get(key, "an integer");
  if (auto i = n->as_integer()) return i->get();
  fail(key, "an integer", kind(*n));
}

std::int64_t TomlView::integer(std::string_view key, std::int64_t lo, std::int64_t hi) const {
  const toml::node* n = get(key, range(lo, hi));
  const auto* i = n->as_integer();
  if (!i) fail(key, range(lo, hi), kind(*n));
  if (i->get() < lo || i->get() > hi) fail(key, range(lo, hi), std::to_string(i->get()));
  return i->get();
}

std::int64_t TomlView::integer_or(std::string_view key, std::int64_t lo, std::int64_t hi,
                                  std::int64_t def) const {
  used_.emplace(key);
  return has(key) ? integer(key, lo, hi) : def;
}

bool TomlView::boolean(std::string_view key) const {
  const toml::node* n = get(key, "true or false");
  if (auto b = n->as_boolean()) return b->get();
  fail(key, "true or false", kind(*n));
}

std::optional<bool> TomlView::opt_boolean(std::string_view key) const {
  used_.emplace(key);
  if (!has(key)) return std::nullopt;
  return boolean(key);
}

std::vector<double> TomlView::numbers(std::string_view key, std::size_t count) const {
  const std::string expected = fmt::format("an array of {} numbers", count);
  const toml::node* n = get(key, expected);
  const toml::array* a = n->as_array();
  if (!a || a->size() != count)
    fail(key, expected, a ? fmt::format("{} elements", a->size()) : kind(*n));
  std::vector<double> v;
  for (std::size_t i = 0; i < count; ++i)
    v.push_back(number_node(*a->get(i), fmt::format("{}[{}]", field(key), i), false));
  return v;
}

glm::dvec3 TomlView::vec3(std::string_view key) const {
  const auto v = numbers(key, 3);
  return {v[0], v[1], v[2]};
}

std::vector<double> TomlView::number_rows(std::string_view key, std::size_t rows,
                                          std::size_t cols) const {
  const std::string expected = fmt::format("a {}×{} array of rows", rows, cols);
  const toml::node* n = get(key, expected);
  const toml::array* a = n->as_array();
  if (!a || a->size() != rows)
    fail(key, expected, a ? fmt::format("{} rows", a->size()) : kind(*n));
  std::vector<double> m;
  m.reserve(rows * cols);
  for (std::size_t r = 0; r < rows; ++r) {
    const toml::array* row = a->get(r)->as_array();
    const std::string rf = fmt::format("{}[{}]", field(key), r);
    if (!row || row->size() != cols)
      throw InputError(file_, rf, fmt::format("a row of {} numbers", cols),
                       row ? fmt::format("{} elements", row->size()) : kind(*a->get(r)));
    for (std::size_t c = 0; c < cols; ++c)
      m.push_back(number_node(*row->get(c), fmt::format("{}[{}]", rf, c), false));
  }
  return m;
}

glm::dmat3 TomlView::mat3_rows(std::string_view key) const {
  const auto rows = number_rows(key, 3, 3);
  glm::dmat3 m(0.0);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m[c][r] = rows[std::size_t(r * 3 + c)];
  return m;
}

std::vector<glm::dvec3> TomlView::points(std::string_view key) const {
  const toml::node* n = get(key, "an array of [x, y, z] points");
  const toml::array* a = n->as_array();
  if (!a) fail(key, "an array of [x, y, z] points", kind(*n));
  if (a->size() > 10000) fail(key, "at most 10000 points", std::to_string(a->size()));
  std::vector<glm::dvec3> pts;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::array* p = a->get(i)->as_array();
    const std::string pf = fmt::format("{}[{}]", field(key), i);
    if (!p || p->size() != 3) throw InputError(file_, pf, "a point [x, y, z]");
    glm::dvec3 v;
    for (std::size_t c = 0; c < 3; ++c)
      v[int(c)] = number_node(*p->get(c), fmt::format("{}[{}]", pf, c), false);
    pts.push_back(v);
  }
  return pts;
}

std::vector<std::string> TomlView::strings(std::string_view key) const {
  const toml::node* n = get(key, "an array of strings");
  const toml::array* a = n->as_array();
  if (!a) fail(key, "an array of strings", kind(*n));
  std::vector<std::string> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const auto* s = a->get(i)->as_string();
    if (!s)
      throw InputError(file_, fmt::format("{}[{}]", field(key), i), "a string", kind(*a->get(i)));
    out.push_back(s->get());
  }
  return out;
}

std::vector<std::int64_t> TomlView::integers(std::string_view key, std::int64_t lo, std::int64_t hi,
                                             std::size_t max_count) const {
  const std::string expected = fmt::format("1 to {} integers in [{}, {}]", max_count, lo, hi);
  const toml::node* n = get(key, expected);
  const toml::array* a = n->as_array();
  if (!a) fail(key, expected, kind(*n));
  if (a->empty() || a->size() > max_count)
    fail(key, expected, fmt::format("{} elements", a->size()));
  std::vector<std::int64_t> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const std::string f = fmt::format("{}[{}]", field(key), i);
    const auto* v = a->get(i)->as_integer();
    if (!v) throw InputError(file_, f, range(lo, hi), kind(*a->get(i)));
    if (v->get() < lo || v->get() > hi)
      throw InputError(file_, f, range(lo, hi), std::to_string(v->get()));
    out.push_back(v->get());
  }
  return out;
}

TomlView TomlView::table(std::string_view key) const {
  const toml::node* n = get(key, "a table");
  if (auto t = n->as_table()) return TomlView(*t, file_, field(key), docs_);
  fail(key, "a table", kind(*n));
}

std::optional<TomlView> TomlView::opt_table(std::string_view key) const {
  used_.emplace(key);
  if (!has(key)) return std::nullopt;
  return table(key);
}

std::vector<TomlView> TomlView::tables(std::string_view key) const {
  std::vector<TomlView> out;
  used_.emplace(key);
  if (!has(key)) return out;
  const std::string expected = "an array of tables ([[" + field(key) + "]])";
  const toml::node* n = get(key, expected);
  const toml::array* a = n->as_array();
  if (!a) fail(key, expected, kind(*n));
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::table* t = a->get(i)->as_table();
    const std::string f = fmt::format("{}[{}]", field(key), i);
    if (!t) throw InputError(file_, f, "a table", kind(*a->get(i)));
    out.emplace_back(*t, file_, f, docs_);
  }
  return out;
}

const toml::node* TomlView::node(std::string_view key) const {
  used_.emplace(key);
  return t_->get(key);
}

void TomlView::unknown(std::string_view key) const {
  fail(key, fmt::format("a known key (see {})", docs_), "unknown key");
}

void TomlView::allow(std::initializer_list<std::string_view> allowed) const {
  for (const auto& [key, node] : *t_) {
    bool ok = false;
    for (auto a : allowed) ok = ok || key.str() == a;
    if (!ok) unknown(key.str());
  }
}

void TomlView::done() const {
  for (const auto& [key, node] : *t_)
    if (!used_.count(key.str())) unknown(key.str());
}

}  // namespace burrbench::data_schema
