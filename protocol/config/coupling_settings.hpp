// [coupling] of a coupled scene (protocol/README.md sections 1, 2, 6-8): one struct for both
// processes, read by protocol/config/coupling_config.hpp. Transport-free and TOML-free.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/coupling_scheme.hpp"
#include "protocol/lcm_url.hpp"

namespace cosim::protocol::config {

struct CouplingSettings {
  static constexpr std::string_view default_lcm_url = kDefaultLcmUrl;
  /// A_T is an int32 on the wire; a million substeps per LB step is beyond any sheet of the
  /// paper, whose A_T is 150.
  static constexpr int time_ratio_max = 1000000;
  /// A day: longer is a typo, and the milliseconds of PeerWatch stay far from overflow.
  static constexpr double timeout_max_s = 86400.0;

  int time_ratio = 150;               ///< A_T = dt_LB / dt_CG (Eq. 16), CGP substeps per LB step
  std::int64_t rigid_steps = 0;       ///< spin-up LB steps with the sheets held rigid
  double handshake_timeout_s = 120.0; ///< no hello_t / welcome_t within it: exit 4
  double peer_timeout_s = 30.0;       ///< the peer silent this long: stop_t(4), exit 4
  double resend_after_s = 0.5;        ///< silence before a resend_t; < peer_timeout_s
  std::string lcm_url = std::string(default_lcm_url);  ///< protocol/lcm_url.hpp
  std::string channel_prefix = "COSIM_";               ///< protocol/channels.hpp
  /// Coupled checkpoints (DESIGN 2.4) every this many LB steps into OUTPUT/checkpoints/;
  /// 0: none (a clean abort still writes one).
  std::int64_t checkpoint_every = 0;
  /// serial (the paper's), implicit sub-iterations or parallel (protocol/coupling_scheme.hpp).
  protocol::SchemeSettings scheme;
};

/// Why `v` cannot be A_T (time_ratio, --time-ratio), or nothing:
/// "must be an integer from 1 to 1000000 (A_T = dt_LB / dt_CG: CGP substeps per LB step)".
std::optional<std::string> time_ratio_problem(std::int64_t v);

}  // namespace cosim::protocol::config
