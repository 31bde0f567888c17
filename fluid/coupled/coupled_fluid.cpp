// The fluid server's coupled run: the coordinator (fluid/coupled/coordinator.hpp) over the
// session layer, the fluid (fluid/coupled/fluid_run.hpp), and the scheme that drives both
// step by step (fluid/schemes/), chosen by the scene's [coupling] scheme.
#include "fluid/coupled/coupled_fluid.hpp"

#include <exception>
#include <memory>
#include <optional>

#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"
#include "fluid/coupled/step_driver.hpp"
#include "fluid/domain/fluid_domain.hpp"
#include "fluid/io/fluid_log.hpp"
#include "fluid/schemes/fluid_scheme.hpp"
#include "common/run/checkpoint_file.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/run/exit_codes.hpp"

namespace cosim::fluid {

namespace {

namespace exit_code = protocol::exit_code;

/// After the handshake: the fluid, the restart, the scheme's LB steps.
int run_steps(const FluidScene& scene, const CoupledFluidOptions& options, Coordinator& coord, FluidScheme& scheme,
              FluidDomain& domain) {
  FluidRun run(scene, options, coord, scheme, domain);
  std::optional<int> failed;
  const std::int64_t first_step = run.start(failed);
  if (failed) return *failed;
  return drive_steps(coord, run, scheme, first_step);
}

int run_coupled(const FluidScene& scene, const CoupledFluidOptions& options, Coordinator& coord, FluidScheme& scheme,
                FluidDomain& domain) {
  if (auto e = coord.open()) return coord.end(*e);
  // A restart awaits the checkpoint's solid_state_t from the start, so that the solid's
  // republished message passes the step-window check even if it comes before the
  // checkpoint is read (an unreadable file is reported by FluidRun::start, after the
  // handshake).
  if (!options.restart.empty()) {
    try {
      const protocol::CheckpointReader r(options.restart);
      // The in-flight solid_state_t may come during the handshake: its A_T is the checkpoint's.
      coord.expect_restart(r.int64_attr("step"), scheme.restart_key(r),
                           r.has("time_ratio") ? static_cast<int>(r.int64_attr("time_ratio"))
                                               : scene.coupling->time_ratio);
    } catch (const std::exception&) {
    }
  }
  if (auto e = coord.handshake()) return coord.end(*e);
  try {
    return run_steps(scene, options, coord, scheme, domain);
  } catch (const std::exception& x) {  // output or system errors after the handshake
    return coord.stop_and_end({exit_code::system, x.what(), false}, coord.awaited_step());
  }
}

}  // namespace

int run_coupled_fluid(const FluidScene& scene, const CoupledFluidOptions& options, std::ostream& out,
                      std::ostream& err) {
  SerialDomain domain(scene.params);
  return run_coupled_fluid(scene, options, out, err, domain);
}

int run_coupled_fluid(const FluidScene& scene, const CoupledFluidOptions& options, std::ostream& out,
                      std::ostream& err, FluidDomain& domain) {
  protocol::hdf5_no_exit_cleanup();
  if (!scene.coupling) {
    fluid_log().error(err) << scene.path << ": not a coupled scene (no [coupling] section)";
    return exit_code::bad_input;
  }
  if (options.token.empty()) {
    fluid_log().error(err) << "a coupled run needs the run's token: --token TOKEN or COSIM_RUN_TOKEN";
    return exit_code::bad_input;
  }
  const std::unique_ptr<FluidScheme> scheme =
      make_fluid_scheme(scene.coupling->scheme, scene.steps, scene.coupling->rigid_steps);
  Coordinator coord(scene, options, *scheme, out);
  const int code = run_coupled(scene, options, coord, *scheme, domain);
  if (code != exit_code::ok) fluid_log().error(err) << "coupled run stopped: " << coord.last_reason();
  return code;
}

}  // namespace cosim::fluid
