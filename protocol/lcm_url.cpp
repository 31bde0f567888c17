#include "protocol/lcm_url.hpp"

#include <charconv>
#include <cstdint>
#include <system_error>

namespace cosim::protocol {

namespace {

/// A decimal number without sign or leading zeros (but "0"), at most `max`.
bool decimal(std::string_view s, unsigned max, unsigned& out) {
  if (s.empty() || s.size() > 5 || (s.size() > 1 && s[0] == '0')) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && out <= max;
}

/// "A.B.C.D" with A in 224..239: an IPv4 multicast group.
bool multicast_group(std::string_view addr) {
  unsigned part[4] = {};
  for (int i = 0; i < 4; ++i) {
    const std::size_t dot = i < 3 ? addr.find('.') : addr.size();
    if (dot == std::string_view::npos || !decimal(addr.substr(0, dot), 255, part[i])) return false;
    addr = i < 3 ? addr.substr(dot + 1) : std::string_view();
  }
  return part[0] >= 224 && part[0] <= 239;
}

}  // namespace

std::optional<std::string> lcm_url_problem(std::string_view url) {
  const std::string allowed =
      "a coupled run talks over udpm://ADDR:PORT?ttl=0 (an IPv4 multicast ADDR, and ttl=0 "
      "the whole query), so that packets never leave this machine (default " +
      std::string(kDefaultLcmUrl) + "), or over memq:// (one process)";
  if (url == "memq://") return std::nullopt;
  if (url.starts_with("memq://"))
    return "not allowed: memq:// takes nothing after it; " + allowed;
  if (!url.starts_with("udpm://")) return "not allowed: " + allowed;
  const std::string_view rest = url.substr(7);
  const std::size_t q = rest.find('?');
  const std::string_view where = rest.substr(0, q);
  const std::string_view query = q == std::string_view::npos ? std::string_view() : rest.substr(q + 1);

  // The query first: it is what keeps the packets on this machine.
  bool ttl0 = false;
  for (std::string_view items = query; !items.empty();) {
    const std::size_t amp = items.find('&');
    const std::string_view item = items.substr(0, amp);
    items = amp == std::string_view::npos ? std::string_view() : items.substr(amp + 1);
    if (item.starts_with("ttl=") && item != "ttl=0")
      return std::string(item) + " is not allowed: the ttl must be 0; " + allowed;
    if (item == "ttl=0" && ttl0) return "ttl=0 twice is not allowed: give it once; " + allowed;
    if (item != "ttl=0") {
      std::string why = "the query item ";  // built up: GCC 12 warns falsely (-Wrestrict)
      why.append(1, '"').append(item).append("\" is not allowed: ttl=0 must be the whole query; ");
      return why + allowed;
    }
    ttl0 = true;
  }
  if (!ttl0) return "has no ttl=0: " + allowed;

  const std::size_t colon = where.rfind(':');
  unsigned port = 0;
  if (colon == std::string_view::npos || !multicast_group(where.substr(0, colon)) ||
      !decimal(where.substr(colon + 1), 65535, port) || port == 0) {
    std::string why(1, '"');  // built up: GCC 12 warns falsely (-Wrestrict)
    why.append(where).append("\" is not ADDR:PORT with an IPv4 multicast ADDR (224.0.0.0 to "
                             "239.255.255.255) and a PORT from 1 to 65535; ");
    return why + allowed;
  }
  return std::nullopt;
}

}  // namespace cosim::protocol
