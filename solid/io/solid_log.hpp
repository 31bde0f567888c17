// The solid server's logger (and the solid library's, sdk/solid.cpp): its lines start
// "solid: " (common/log/logger.hpp). The one place the solid names itself; --quiet passes
// Level::info (no progress line).
#pragma once

#include "common/log/logger.hpp"

namespace cosim::solid {

inline log::Logger solid_log(log::Level threshold = log::Level::progress) { return log::Logger("solid", threshold); }

}  // namespace cosim::solid
