#include "toml_util.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema {

namespace {
constexpr std::uintmax_t kMaxTomlBytes = 16u << 20;
}

toml::table parse_toml_file(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(file, "<file>", "an existing regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxTomlBytes)
    throw InputError(file, "<file>", "a TOML file of at most 16 MiB", ec ? ec.message() : std::to_string(size) + " bytes");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(file, "<file>", "a readable file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_toml_text(ss.str(), file);
}

toml::table parse_toml_text(std::string_view text, const std::string& file) {
  if (text.size() > kMaxTomlBytes)
    throw InputError(file, "<file>", "a TOML file of at most 16 MiB", std::to_string(text.size()) + " bytes");
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw InputError(file, fmt::format("line {} column {}", b.line, b.column), "valid TOML",
                     std::string(e.description()));
  }
}

}  // namespace burrbench::data_schema

namespace burrbench::data_schema::detail {

namespace {

std::string kind(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a float";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date/time";
  }
}
}

std::vector<std::string> TomlView::keys() const {
  std::vector<std::string> k;
  for (const auto& [key, node] : *t_) k.emplace_back(key.str());
  return k;
}

const toml::node* TomlView::get(const std::string& key, const char* expected) {
  used_.insert(key);
  const toml::node* n = t_->get(key);
  if (!n) throw InputError(file_, field(key), expected, "missing");
  return n;
}

double TomlView::number_node(const toml::node& n, const std::string& f, bool allow_inf) const {
  double v = 0;
  if (auto i = n.as_integer()) v = double(i->get());
  else if (auto d = n.as_floating_point()) v = d->get();
  else if (auto s = n.as_string(); s && allow_inf && s->get() == "inf") v = INFINITY;
  else throw InputError(file_, f, allow_inf ? "a number or \"inf\"" : "a number", kind(n));
  if (std::isnan(v) || (std::isinf(v) && !(allow_inf && v > 0)))
    throw InputError(file_, f, allow_inf ? "a finite number or +inf" : "a finite number", fmt::format("{}", v));
  return v;
}

std::string TomlView::str(const std::string& key) {
  const toml::node* n = get(key, "a string");
  if (auto s = n->as_string()) return s->get();
  throw InputError(file_, field(key), "a string", kind(*n));
}

std::optional<std::string> TomlView::opt_str(const std::string& key) {
  if (!has(key)) return std::nullopt;
  return str(key);
}

double TomlView::num(const std::string& key) { return number_node(*get(key, "a number"), field(key), false); }

std::optional<double> TomlView::opt_num(const std::string& key) {
  if (!has(key)) return std::nullopt;
  return num(key);
}

double TomlView::num_or_inf(const std::string& key) {
  return number_node(*get(key, "a number or \"inf\""), field(key), true);
}

std::int64_t TomlView::integer(const std::string& key) {
  const toml::node* n = get(key, "an integer");
  if (auto i = n->as_integer()) return i->get();
  throw InputError(file_, field(key), "an integer", kind(*n));
}

bool TomlView::boolean(const std::string& key) {
  const toml::node* n = get(key, "true or false");
  if (auto b = n->as_boolean()) return b->get();
  throw InputError(file_, field(key), "true or false", kind(*n));
}

std::optional<bool> TomlView::opt_boolean(const std::string& key) {
  if (!has(key)) return std::nullopt;
  return boolean(key);
}

glm::dvec3 TomlView::vec3(const std::string& key) {
  const toml::node* n = get(key, "an array of 3 numbers");
  const toml::array* a = n->as_array();
  if (!a || a->size() != 3)
    throw InputError(file_, field(key), "an array of 3 numbers", a ? fmt::format("{} elements", a->size())
                                                                   : kind(*n));
  glm::dvec3 v;
  for (int i = 0; i < 3; ++i) v[i] = number_node(*a->get(std::size_t(i)), fmt::format("{}[{}]", field(key), i), false);
  return v;
}

glm::dmat3 TomlView::mat3_rows(const std::string& key) {
  const toml::node* n = get(key, "a 3×3 array of rows");
  const toml::array* a = n->as_array();
  if (!a || a->size() != 3) throw InputError(file_, field(key), "a 3×3 array of rows [[..],[..],[..]]");
  glm::dmat3 m(0.0);
  for (std::size_t r = 0; r < 3; ++r) {
    const toml::array* row = a->get(r)->as_array();
    const std::string rf = fmt::format("{}[{}]", field(key), r);
    if (!row || row->size() != 3) throw InputError(file_, rf, "a row of 3 numbers");
    for (std::size_t c = 0; c < 3; ++c)
      m[int(c)][int(r)] = number_node(*row->get(c), fmt::format("{}[{}]", rf, c), false);
  }
  return m;
}

std::vector<glm::dvec3> TomlView::points(const std::string& key) {
  const toml::node* n = get(key, "an array of [x, y, z] points");
  const toml::array* a = n->as_array();
  if (!a) throw InputError(file_, field(key), "an array of [x, y, z] points", kind(*n));
  if (a->size() > 10000) throw InputError(file_, field(key), "at most 10000 points", std::to_string(a->size()));
  std::vector<glm::dvec3> pts;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::array* p = a->get(i)->as_array();
    const std::string pf = fmt::format("{}[{}]", field(key), i);
    if (!p || p->size() != 3) throw InputError(file_, pf, "a point [x, y, z]");
    glm::dvec3 v;
    for (std::size_t c = 0; c < 3; ++c) v[int(c)] = number_node(*p->get(c), fmt::format("{}[{}]", pf, c), false);
    pts.push_back(v);
  }
  return pts;
}

TomlView TomlView::table(const std::string& key) {
  const toml::node* n = get(key, "a table");
  if (auto t = n->as_table()) return TomlView(*t, file_, field(key));
  throw InputError(file_, field(key), "a table", kind(*n));
}

std::optional<TomlView> TomlView::opt_table(const std::string& key) {
  if (!has(key)) return std::nullopt;
  return table(key);
}

std::vector<TomlView> TomlView::tables(const std::string& key) {
  std::vector<TomlView> out;
  if (!has(key)) {
    used_.insert(key);
    return out;
  }
  const toml::node* n = get(key, "an array of tables");
  const toml::array* a = n->as_array();
  if (!a) throw InputError(file_, field(key), "an array of tables ([[" + field(key) + "]])", kind(*n));
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::table* t = a->get(i)->as_table();
    const std::string f = fmt::format("{}[{}]", field(key), i);
    if (!t) throw InputError(file_, f, "a table");
    out.emplace_back(*t, file_, f);
  }
  return out;
}

void TomlView::done() const {
  for (const auto& [key, node] : *t_)
    if (!used_.count(std::string(key.str())))
      throw InputError(file_, field(std::string(key.str())), "a known key (see docs/formats.md)", "unknown key");
}

toml::table provenance_to_toml(const Provenance& p) {
  toml::array inputs;
  for (const auto& f : p.inputs) inputs.push_back(toml::table{{"path", f.path}, {"sha256", f.sha256}});
  return toml::table{{"software_version", p.software_version},
                     {"command_line", p.command_line},
                     {"created_utc", p.created_utc},
                     {"inputs", inputs}};
}

Provenance provenance_from_toml(TomlView v) {
  Provenance p;
  p.software_version = v.str("software_version");
  p.command_line = v.str("command_line");
  p.created_utc = v.str("created_utc");
  for (auto& f : v.tables("inputs")) {
    p.inputs.push_back({f.str("path"), f.str("sha256")});
    f.done();
  }
  v.done();
  return p;
}

}  // namespace burrbench::data_schema::detail
