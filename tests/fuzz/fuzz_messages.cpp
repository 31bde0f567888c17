// libFuzzer target (optional, Debian's clang; tests/fuzz/README.md): the bytes of one LCM
// message through decode_checked and the checks of protocol/message_checks.hpp, as each of
// the six message types. Any crash, sanitizer report, or a decode that disagrees with the
// layout check is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "protocol/message_checks.hpp"

namespace {

template <class M>
void one(const std::uint8_t* data, std::size_t size, const cosim::protocol::Expectation& e) {
  const bool layout_ok = !cosim::protocol::check_encoding(static_cast<const M*>(nullptr), data, size);
  M m{};
  const auto refused = cosim::protocol::decode_checked(data, size, m);
  if (layout_ok == refused.has_value()) std::abort();  // the two must agree
  if (refused) return;
  const auto r = cosim::protocol::check(m, e);
  if (r && r->what.find('\n') != std::string::npos) std::abort();  // one line
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  cosim::protocol::Expectation e;
  e.token = "0123456789abcdef";
  e.num_cgps = 4;
  e.lowest_step = 0;
  e.highest_step = 12;
  e.time_ratio = 150;
  one<cosimlcm::hello_t>(data, size, e);
  one<cosimlcm::welcome_t>(data, size, e);
  one<cosimlcm::solid_state_t>(data, size, e);
  one<cosimlcm::fluid_state_t>(data, size, e);
  one<cosimlcm::resend_t>(data, size, e);
  one<cosimlcm::stop_t>(data, size, e);
  return 0;
}
