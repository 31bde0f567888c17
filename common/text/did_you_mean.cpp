#include "common/text/did_you_mean.hpp"

#include <algorithm>

namespace cosim::protocol {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0u : 1u)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string_view closest_name(std::string_view got, const std::vector<std::string_view>& allowed) {
  std::size_t best = got.size() >= 8 ? 4 : 3;  // up to 2 edits, 3 for long names
  std::string_view pick;
  for (const std::string_view a : allowed) {
    const std::size_t d = edit_distance(got, a);
    if (d < best) best = d, pick = a;
  }
  if (pick.empty() && got.size() >= 2)  // an ending left off: theta -> theta_deg, corotation -> corotational
    for (const std::string_view a : allowed)
      if (a.size() > got.size() && a.starts_with(got) && (pick.empty() || a.size() < pick.size())) pick = a;
  return pick;
}

std::string did_you_mean(std::string_view got, const std::vector<std::string_view>& allowed) {
  const std::string_view pick = closest_name(got, allowed);
  if (pick.empty()) return "";
  std::string out(" (did you mean \"");  // built up: GCC 12 warns falsely (-Wrestrict)
  return out.append(pick).append("\"?)");
}

}  // namespace cosim::protocol
