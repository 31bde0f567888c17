#include "protocol/config/scene_reader.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "common/text/did_you_mean.hpp"

namespace cosim::protocol::config {

namespace {

namespace fs = std::filesystem;

std::string shorten(std::string s, std::size_t max = 60) {
  if (s.size() > max) s = s.substr(0, max - 3) + "...";
  return s;
}

/// A value as the user wrote it (close enough): strings quoted, arrays inline.
std::string show_node(const toml::node& n) {
  if (const auto* s = n.as_string()) return quoted(s->get());
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  if (const auto* d = n.as_floating_point()) return format_double(d->get());
  if (const auto* b = n.as_boolean()) return b->get() ? "true" : "false";
  if (const auto* a = n.as_array()) {
    std::string out = "[";
    for (std::size_t i = 0; i < a->size(); ++i) out += (i ? ", " : "") + show_node(*a->get(i));
    return shorten(out + "]");
  }
  if (n.is_table()) return "{...}";
  std::ostringstream os;
  n.visit([&](const auto& v) { os << v; });
  return shorten(one_line(os.str()));
}

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date or time";
  }
}

toml::table parse_file(const std::string& path) {
  std::error_code ec;
  const auto refuse = [&](const char* why) {
    return ConfigError(one_line(path + ": cannot read the scene file: " + why));
  };
  if (!fs::exists(path, ec)) throw refuse("no such file");
  if (!fs::is_regular_file(path, ec)) throw refuse("not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw refuse("permission denied?");
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return toml::parse(text.str(), path);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw ConfigError(one_line(path + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) +
                               ": TOML syntax error: " + std::string(e.description())));
  }
}

std::string header(std::string_view name, bool array) {
  std::string out(array ? "[[" : "[");  // built up: GCC 12 warns falsely (-Wrestrict)
  return out.append(name).append(array ? "]]" : "]");
}

bool used(const SectionSchema& s, bool coupled) {
  return s.use == Use::Always || (s.use == Use::Coupled) == coupled;
}

bool contains(const std::vector<std::string_view>& v, std::string_view x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

}  // namespace

// ---- text ----

std::string one_line(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return s;
}

std::string command_line_problem(const std::string& option, const std::string& value,
                                 const std::string& msg) {
  return one_line("command line: " + option + " = " + value + ": " + msg);
}

std::string quoted(const std::string& s) {
  std::string out(1, '"');  // not "\"" + ...: GCC 12 warns falsely (-Wrestrict)
  out += one_line(s);
  out += '"';
  return shorten(out);
}

std::string format_double(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string suggestion(std::string_view got, const std::vector<std::string_view>& allowed) {
  return protocol::did_you_mean(got, allowed);
}

std::string join(const std::vector<std::string_view>& items, std::string_view prefix,
                 std::string_view suffix) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i) out += ", ";
    out += prefix;
    out += items[i];
    out += suffix;
  }
  return out;
}

// ---- Table ----

std::optional<double> Table::number(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  double v = 0.0;
  if (const auto* i = n->as_integer())
    v = double(i->get());
  else if (const auto* d = n->as_floating_point())
    v = d->get();
  else
    bad(k, std::string("must be a number, not ") + type_name(*n));
  if (!std::isfinite(v)) bad(k, "must be a finite number");
  return v;
}

std::optional<std::int64_t> Table::integer(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  const auto* i = n->as_integer();
  if (!i) bad(k, std::string("must be an integer, not ") + type_name(*n));
  return i->get();
}

std::optional<bool> Table::boolean(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  const auto* b = n->as_boolean();
  if (!b) bad(k, std::string("must be true or false, not ") + type_name(*n));
  return b->get();
}

std::optional<std::string> Table::string(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  const auto* s = n->as_string();
  if (!s) bad(k, std::string("must be a string, not ") + type_name(*n));
  return s->get();
}

std::optional<int> Table::integer_in(std::string_view k, std::int64_t lo, std::int64_t hi,
                                     const std::string& why) const {
  const auto v = integer(k);
  if (!v) return std::nullopt;
  if (*v < lo || *v > hi)
    bad(k, "must be an integer from " + std::to_string(lo) + " to " + std::to_string(hi) + why);
  return int(*v);
}

std::optional<double> Table::positive(std::string_view k, const std::string& what) const {
  const auto v = number(k);
  if (v && !(*v > 0.0)) bad(k, "must be > 0 (" + what + ")");
  return v;
}

std::optional<double> Table::length_um(std::string_view k, const std::string& what) const {
  const auto v = positive(k, what);
  if (v && !(*v >= length_min_um && *v <= length_max_um))
    bad(k, "must be in [1e-9, 1e6] micrometres (" + what + ")");
  return v;
}

std::optional<std::size_t> Table::choice(std::string_view k,
                                         const std::vector<const char*>& allowed) const {
  const std::optional<std::string> s = string(k);
  if (!s) return std::nullopt;
  for (std::size_t i = 0; i < allowed.size(); ++i)
    if (*s == allowed[i]) return i;
  const std::vector<std::string_view> names(allowed.begin(), allowed.end());
  bad(k, "must be one of " + join(names, "\"", "\"") + suggestion(*s, names));
}

std::optional<std::vector<double>> Table::numbers(std::string_view k, std::size_t n_min,
                                                  std::size_t n_max, const std::string& shape) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  const toml::array* a = n->as_array();
  if (!a || a->size() < n_min || a->size() > n_max) bad(k, shape);
  std::vector<double> out;
  for (const toml::node& e : *a) {
    double v = 0.0;
    if (const auto* i = e.as_integer())
      v = double(i->get());
    else if (const auto* d = e.as_floating_point())
      v = d->get();
    else
      bad(k, shape);
    if (!std::isfinite(v)) bad(k, shape);
    out.push_back(v);
  }
  return out;
}

void Table::bad(std::string_view k, const std::string& msg) const {
  reader_->bad(*node(k), key(k), msg);
}

void Table::missing(std::string_view k, const std::string& what) const {
  reader_->fail(line_, key(k) + ": missing; " + what);
}

void Table::fail(const std::string& what) const { reader_->fail(line_, what); }

std::string Table::show(std::string_view k) const { return show_node(*node(k)); }

std::uint32_t Table::line_of(std::string_view k) const { return node(k)->source().begin.line; }

// ---- SceneReader ----

SceneReader::SceneReader(std::string path, Process process)
    : path_(std::move(path)), process_(process), root_(parse_file(path_)) {}

void SceneReader::fail(std::uint32_t line, const std::string& what) const {
  std::string where = path_;
  if (line > 0) where += ":" + std::to_string(line);
  throw ConfigError(one_line(where + ": " + what));
}

void SceneReader::bad(const toml::node& n, const std::string& key, const std::string& msg) const {
  fail(n.source().begin.line, key + " = " + show_node(n) + ": " + msg);
}

Table SceneReader::section(std::string_view name) const {
  const toml::node* n = root_.get(name);
  if (!n) return Table(*this, nullptr, std::string(name), 0);
  return Table(*this, n->as_table(), std::string(name), n->source().begin.line);
}

std::vector<Table> SceneReader::array_section(std::string_view name) const {
  std::vector<Table> out;
  const toml::node* n = root_.get(name);
  if (!n) return out;
  std::size_t i = 0;
  for (const toml::node& e : *n->as_array())  // shape checked by check_sections
    out.emplace_back(*this, e.as_table(), std::string(name) + "[" + std::to_string(i++) + "]",
                     e.source().begin.line);
  return out;
}

std::uint32_t SceneReader::section_line(std::string_view name) const {
  const toml::node* n = root_.get(name);
  return n ? n->source().begin.line : 0;
}

void SceneReader::check_sections(const std::vector<SectionSchema>& schema) const {
  const bool coupled = this->coupled();
  const Process other = process_ == Process::Fluid ? Process::Solid : Process::Fluid;

  // The sections of this kind of scene, for messages: this process's, then (coupled) the
  // other's, which it leaves unread.
  std::vector<std::string_view> names;
  std::string list;
  for (const SectionSchema& s : schema) {
    if (!used(s, coupled)) continue;
    names.push_back(s.name);
    list += (list.empty() ? "" : ", ") + header(s.name, s.array);
  }
  if (coupled) {
    std::string others;
    for (const SectionOwner& row : scene_sections())
      if (!reads(process_, row.owner) && !contains(names, row.name)) {
        names.push_back(row.name);
        others += (others.empty() ? "" : ", ") + header(row.name, row.array);
      }
    list += std::string("; the ") + process_name(other) + "'s " + others;
  }

  for (auto&& [k, v] : root_) {
    const std::string name(k.str());
    const std::uint32_t line = k.source().begin.line;
    const auto own = std::find_if(schema.begin(), schema.end(),
                                  [&](const SectionSchema& s) { return s.name == name; });
    const SectionOwner* row = find_section_owner(name);
    if (own == schema.end() || !used(*own, coupled)) {
      if (row && !reads(process_, row->owner)) {
        if (coupled) continue;  // the other process's (it checks them)
        fail(line, header(name, false) + ": a " + process_name(other) +
                       " section needs a [coupling] section (a coupled scene); " +
                       (process_ == Process::Fluid ? "a fluid-only scene has no sheets"
                                                   : "a standalone solid scene has no flow"));
      }
      if (own != schema.end() && coupled && own->use == Use::Standalone)
        fail(line, header(own->name, own->array) +
                       ": not used in a coupled scene (one with [coupling]): the fluid drives "
                       "the sheets; remove the section, or remove [coupling] for a standalone run");
      if (v.is_table() || v.is_array_of_tables())
        fail(line, header(name, false) + ": unknown section; allowed: " + list + suggestion(name, names));
      bad(v, name, "unknown key at the top level; keys belong in one of the sections " + list +
                       suggestion(name, names));
    }

    // This process's keys of the section; of a shared one also the other's (left unread in
    // a coupled scene).
    std::vector<std::string_view> keys = own->keys, others;
    if (row)
      for (const KeyOwner& ko : row->keys) (reads(process_, ko.owner) ? keys : others).push_back(ko.key);
    std::vector<std::string_view> allowed = keys;
    if (coupled) allowed.insert(allowed.end(), others.begin(), others.end());

    const auto check_keys = [&](const toml::table& t, const std::string& scope) {
      for (auto&& [kk, vv] : t) {
        const std::string key(kk.str());
        if (contains(allowed, key)) continue;
        if (contains(others, key))
          bad(vv, scope + "." + key,
              std::string("is the ") + process_name(other) +
                  "'s: only in a coupled scene (one with a [coupling] section)");
        bad(vv, scope + "." + key,
            "unknown key in " + header(own->name, own->array) + "; allowed: " + join(allowed) +
                suggestion(key, allowed));
      }
    };
    if (own->array) {
      if (!v.is_array_of_tables())
        fail(v.source().begin.line,
             (v.is_table() ? header(name, false) : name) +
                 ": must be an array of tables: write each as " + header(name, true) + " with keys " +
                 join(allowed));
      std::size_t i = 0;
      for (const toml::node& e : *v.as_array())
        check_keys(*e.as_table(), name + "[" + std::to_string(i++) + "]");
    } else {
      if (!v.is_table())
        bad(v, name, "must be a table: a section " + header(name, false) + " with keys " + join(allowed));
      check_keys(*v.as_table(), name);
    }
  }
}

}  // namespace cosim::protocol::config
