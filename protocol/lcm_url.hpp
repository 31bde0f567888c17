// The one rule for the LCM URL of a coupled run (DESIGN 2.3, protocol/README.md section 1):
// both servers apply it to the scene's [coupling] lcm_url and to their --lcm-url.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace cosim::protocol {

/// The URL of a coupled run when the scene names none.
inline constexpr std::string_view kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

/// Why `url` may not carry a coupled run, or nothing if it may. Allowed are exactly two
/// forms: "memq://" (LCM's in-process queue: one process, the tests) and
/// "udpm://ADDR:PORT?ttl=0" with ADDR an IPv4 multicast group (224.0.0.0 to
/// 239.255.255.255), PORT 1 to 65535 and a query of exactly "ttl=0", so that no packet
/// leaves this machine. Any other provider (tcpq://, file://, ...), another ttl, a second
/// ttl or any other query item is refused. The reason is one line, e.g.
///   ttl=1 is not allowed: the ttl must be 0; a coupled run talks over ...
std::optional<std::string> lcm_url_problem(std::string_view url);

}  // namespace cosim::protocol
