// Small text helpers for the one-line messages and reports of both servers.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

namespace cosim::protocol {

/// `s` on one line: control characters become spaces, trailing spaces go.
inline std::string one_line(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

/// One number through a printf format, e.g. fmt("%.4g", x).
inline std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

/// `s` in double quotes, printable ASCII as it is, anything else (and '"', '\\') as \xNN:
/// a value from a file or a message shown safely on one line.
inline std::string escaped(std::string_view s) {
  std::string q = "\"";
  for (const char ch : s) {
    const auto b = static_cast<unsigned char>(ch);
    if (b >= 0x20 && b < 0x7f && ch != '"' && ch != '\\') {
      q += ch;
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", static_cast<unsigned>(b));
      q += hex;
    }
  }
  return q + "\"";
}

/// "  " before every line of a multi-line text.
inline std::string indent(const std::string& text) {
  std::string out;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    out += "  " + text.substr(start, end - start) + "\n";
    start = end + 1;
  }
  return out;
}

}  // namespace cosim::protocol
