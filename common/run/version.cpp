#include "common/run/version.hpp"

#include "cosim_version.h"  // generated at build time (cmake/version.cmake)

namespace cosim::protocol {

const char* version() { return COSIM_VERSION; }
const char* git_describe() { return COSIM_GIT_DESCRIBE; }
const char* git_commit() { return COSIM_GIT_COMMIT; }

std::string version_line(const std::string& program) {
  return program + " " + COSIM_VERSION + " (git " + COSIM_GIT_DESCRIBE + ", commit " + COSIM_GIT_COMMIT + ")" +
         COSIM_GIT_DIRTY;
}

}  // namespace cosim::protocol
