# Run at build time (cmake -P, from the cosim_version_header target): writes the version
# header OUT from `git describe` and `git rev-parse HEAD` of SOURCE_DIR. The header is
# rewritten only when its text changes, so a commit recompiles common/run/version.cpp (and
# nothing else). Outside a git checkout (a source tarball) the commit reads "unknown".
#   cmake -DSOURCE_DIR=... -DOUT=... -DPROJECT_VERSION=... -P cmake/version.cmake
find_program(GIT git)
set(describe "unknown")
set(commit "unknown")
set(dirty "")
if(GIT)
  execute_process(COMMAND ${GIT} -C ${SOURCE_DIR} describe --always --dirty --tags
                  OUTPUT_VARIABLE out RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(rc EQUAL 0 AND out)
    set(describe "${out}")
  endif()
  execute_process(COMMAND ${GIT} -C ${SOURCE_DIR} rev-parse HEAD
                  OUTPUT_VARIABLE out RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(rc EQUAL 0 AND out)
    set(commit "${out}")
  endif()
endif()
string(FIND "${describe}" "-dirty" at)
if(NOT at EQUAL -1)
  set(dirty " (with uncommitted changes)")
endif()
set(text "/* Generated at build time by cmake/version.cmake; never committed. */
#ifndef COSIM_VERSION_H
#define COSIM_VERSION_H
#define COSIM_VERSION \"${PROJECT_VERSION}\"
#define COSIM_GIT_DESCRIBE \"${describe}\"
#define COSIM_GIT_COMMIT \"${commit}\"
#define COSIM_GIT_DIRTY \"${dirty}\"
#endif
")
set(old "")
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT old STREQUAL text)
  file(WRITE ${OUT} "${text}")
endif()
