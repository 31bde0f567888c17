// libFuzzer target (optional, Debian's clang; tests/fuzz/README.md): the bytes of one scene
// file through the fluid's and the solid's parsers. Their documented exceptions (SceneError,
// SolidSceneError, one line each) are expected; anything else, a crash, a sanitizer report,
// or an accepted scene with a non-finite number (tests/support/scene_invariants.hpp) is a finding.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "fluid/config/scene_config.hpp"
#include "solid/config/solid_scene.hpp"
#include "tests/support/scene_invariants.hpp"

namespace {

const std::string& scratch_file() {
  static const std::string path =
      (std::filesystem::temp_directory_path() / ("cosim_fuzz_scene_" + std::to_string(getpid()) + ".toml"))
          .string();
  return path;
}

[[noreturn]] void finding(const char* parser, const char* what) {
  std::fprintf(stderr, "%s parser: %s\n", parser, what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  {
    std::ofstream out(scratch_file(), std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const std::string why = cosim::test::non_finite(cosim::fluid::load_scene(scratch_file()));
    if (!why.empty()) finding("fluid", ("accepted a scene whose " + why + " is not finite").c_str());
  } catch (const cosim::fluid::SceneError& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) finding("fluid", "a two-line error");
  } catch (const std::exception& e) {
    finding("fluid", e.what());
  }
  try {
    const std::string why = cosim::test::non_finite(cosim::solid::load_solid_scene(scratch_file()));
    if (!why.empty()) finding("solid", ("accepted a scene whose " + why + " is not finite").c_str());
  } catch (const cosim::solid::SolidSceneError& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) finding("solid", "a two-line error");
  } catch (const std::exception& e) {
    finding("solid", e.what());
  }
  return 0;
}
