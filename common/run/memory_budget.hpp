// How the memory of the one machine both servers run on (DESIGN 2.3) is shared, for the
// estimates the scene parsers make before anything is allocated: the fluid plans for at most
// 75 % of it, the solid for at most 20 %, and 5 % stays for the system. A scene whose
// estimate exceeds its side's share is refused, naming the keys that drive it.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <string>

namespace cosim::protocol {

inline constexpr double kFluidMemoryShare = 0.75;
inline constexpr double kSolidMemoryShare = 0.20;

/// This machine's physical memory in bytes; 0 if it cannot be read (then nothing is refused).
inline std::size_t machine_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return 0;
  return std::size_t(pages) * std::size_t(page);
}

/// "1.5 GiB": bytes in the largest binary unit below 1024, one decimal (none for bytes).
inline std::string human_bytes(double b) {
  const char* unit[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (b >= 1024.0 && u < 6) b /= 1024.0, ++u;
  char s[64];
  std::snprintf(s, sizeof s, "%.*f %s", u == 0 ? 0 : 1, b, unit[u]);
  return s;
}

/// "" when `need` bytes fit in `share` of this machine's memory, else "more than 75 % of this
/// machine's memory (17.2 GiB of 23.0 GiB; ...)" for the refusal.
inline std::string beyond_share(double need, double share, const std::string& rest) {
  const std::size_t have = machine_memory_bytes();
  const double allowed = share * double(have);
  if (have == 0 || need <= allowed) return "";
  char pct[16];
  std::snprintf(pct, sizeof pct, "%.0f", 100.0 * share);
  return "more than " + std::string(pct) + " % of this machine's memory (" + human_bytes(allowed) + " of " +
         human_bytes(double(have)) + "; " + rest + ")";
}

}  // namespace cosim::protocol
