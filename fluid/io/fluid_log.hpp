// The fluid server's logger: its lines start "fluid: " (common/log/logger.hpp). The one
// place the fluid names itself; --quiet passes Level::info (no progress line).
#pragma once

#include "common/log/logger.hpp"

namespace cosim::fluid {

inline log::Logger fluid_log(log::Level threshold = log::Level::progress) { return log::Logger("fluid", threshold); }

}  // namespace cosim::fluid
