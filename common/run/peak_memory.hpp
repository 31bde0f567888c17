// The peak memory of this process, for the servers' end-of-run lines (DESIGN 7; issue 8:
// peak memory of each process for the paper's scenes).
#pragma once

#include <sys/resource.h>

namespace cosim::protocol {

/// The largest resident set this process has had so far, in MiB (getrusage's ru_maxrss,
/// which Linux counts in KiB); 0 if it cannot be read.
inline double peak_rss_mib() {
  rusage u{};
  if (getrusage(RUSAGE_SELF, &u) != 0) return 0.0;
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

}  // namespace cosim::protocol
