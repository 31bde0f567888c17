#include "common/run/provenance.hpp"

#include <unistd.h>

#include <chrono>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "common/run/atomic_file.hpp"
#include "common/run/version.hpp"

namespace cosim::protocol {

namespace {

Provenance& state() {
  static Provenance p;
  return p;
}

std::string sh_word(const std::string& w) {
  if (!w.empty() && w.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-./=:,+@%") ==
                        std::string::npos)
    return w;
  std::string q = "'";
  for (const char c : w) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

/// A TOML basic string: '"' and '\\' escaped, control characters as \uXXXX.
std::string toml_string(const std::string& s) {
  std::string q = "\"";
  for (const char ch : s) {
    const auto b = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      q += '\\';
      q += ch;
    } else if (b < 0x20 || b == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\u%04x", static_cast<unsigned>(b));
      q += hex;
    } else {
      q += ch;
    }
  }
  return q + "\"";
}

}  // namespace

void record_invocation(const std::string& program, int argc, char** argv) {
  Provenance& p = state();
  p.program = program;
  p.command_line.clear();
  for (int k = 0; k < argc; ++k) {
    if (k > 0) p.command_line += ' ';
    p.command_line += sh_word(argv[k]);
  }
  p.start_time_utc = utc_now();
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) == 0) p.host = host;
  p.host_cpu = host_cpu();
}

void record_scene(const std::string& path) {
  Provenance& p = state();
  std::error_code ec;
  const std::filesystem::path abs = std::filesystem::absolute(path, ec);
  p.scene_path = ec ? path : abs.lexically_normal().string();
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  p.scene_text = text.str();
}

const Provenance& provenance() {
  Provenance& p = state();
  if (p.start_time_utc.empty()) {  // a library use without main()'s record_invocation
    p.start_time_utc = utc_now();
    p.host_cpu = host_cpu();
  }
  return p;
}

std::string host_cpu() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, model;
  int cpus = 0;
  while (std::getline(in, line)) {
    if (line.rfind("processor", 0) == 0) ++cpus;
    if (model.empty() && line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) model = line.substr(line.find_first_not_of(" \t", colon + 1));
    }
  }
  if (model.empty()) model = "unknown";
  return cpus > 0 ? model + " x " + std::to_string(cpus) + " logical CPUs" : model;
}

std::string provenance_toml(const std::string& scene_copy) {
  const Provenance& p = provenance();
  std::string s = "# Provenance of this output folder (common/run/provenance.hpp)\n";
  const auto kv = [&s](const char* k, const std::string& v) { s += std::string(k) + " = " + toml_string(v) + "\n"; };
  kv("program", p.program);
  kv("version", version());
  kv("git_describe", git_describe());
  kv("git_commit", git_commit());
  kv("command_line", p.command_line);
  kv("start_time_utc", p.start_time_utc);
  kv("host", p.host);
  kv("host_cpu", p.host_cpu);
  kv("scene_path", p.scene_path);
  if (!p.scene_path.empty()) kv("scene_copy", scene_copy);
  return s;
}

namespace {

std::string file_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// DIR/STEM.toml, or, when that file holds another text (an earlier attempt of a run that a
/// restart continues in its folder), the first DIR/STEM.N.toml (N = 2, 3, ...) that is free
/// or holds `text` already: an earlier attempt's record is never overwritten.
std::filesystem::path record_file(const std::filesystem::path& dir, const std::string& stem, const std::string& text) {
  for (int n = 1;; ++n) {
    const std::filesystem::path f = dir / (n == 1 ? stem + ".toml" : stem + "." + std::to_string(n) + ".toml");
    if (!std::filesystem::exists(f) || file_text(f) == text) return f;
  }
}

}  // namespace

void write_provenance_files(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create the output folder " + dir.string() + ": " + ec.message());
  const Provenance& p = provenance();
  std::string scene_copy;
  if (!p.scene_path.empty()) {
    const std::filesystem::path scene = record_file(dir, "scene", p.scene_text);
    write_text_atomically(scene, p.scene_text, PartName::PerProcess);
    scene_copy = scene.filename().string();
  }
  const std::string text = provenance_toml(scene_copy);
  write_text_atomically(record_file(dir, "provenance_" + p.program, text), text,
                        PartName::PerProcess);
}

}  // namespace cosim::protocol
