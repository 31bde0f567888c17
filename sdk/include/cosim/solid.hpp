// The solid library (libcosim_sdk): a solid model from outside the solid server coupled to
// the fluid with one call. The user implements `cosim::sdk::Solid` (the markers at the
// start, and the A_T substeps of one LB step given the fluid sample) and calls
// `cosim::sdk::run(solid, argc, argv)`; the library runs the whole peer of
// protocol/README.md: the command line the launcher passes, the scene's units, the handshake,
// sequence numbers, resends, timeouts, stop_t and the exit codes of section 9. It is the solid
// server's own session (solid/coupled/solid_peer.hpp, protocol/session/), not a second copy.
//
// Units: lattice units throughout (dx, dt_LB, rho_air dx^3): positions in dx, velocities in
// c = dx / dt_LB, densities in rho_air, impulses in rho_air dx^3 c (an impulse over one LB
// step is then numerically a force in F_LB = rho_air c^2 dx^2). Scene gives the SI values.
//
// Spin-up: during the scene's [coupling] rigid_steps the library holds the markers itself and
// answers J_l = -2 rho_l u_l dA_l (section 5, U_B = 0); step() is called from the first free
// step on. Checkpoints and --restart when the solid implements save() and restore().
// Every coupling scheme runs ([coupling] scheme = "serial", "parallel" or "implicit"), through
// the solid server's scheme registry (solid/schemes/): the implicit scheme calls step() once
// per iterate, each from the step's start (restore() of the state save() gave there), so it
// needs save() and restore() (a solid without them is refused with exit code 2).
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

/// What the shared library exports: this interface only (its own code, Eigen's templates and
/// the static libraries inside it stay hidden, so that a program built with other flags never
/// binds to the library's copies of them, nor the library to the program's).
#define COSIM_SDK_API __attribute__((visibility("default")))

namespace cosim::sdk {

/// The arrays of the interface: 3 x N (one column per marker) and N values. Unaligned
/// (plain malloc and free), so that a program built with other flags than the library (no
/// -march=native, another SIMD width: Eigen's alignment differs) exchanges them safely; they
/// convert to and from Eigen::Matrix3Xd and Eigen::VectorXd.
using Matrix3X = Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::ColMajor | Eigen::DontAlign>;
using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor | Eigen::DontAlign>;

/// One [[sheet]] of the scene as the solid server builds it (its flat reference).
struct Sheet {
  int nx = 0, ny = 0;        ///< markers along the width and the height; index i + nx j
  int clamped_rows = 0;      ///< rows j < clamped_rows are held to the plate
  double spacing_w_lb = 0.0;  ///< marker spacing along the width, dx
  double spacing_h_lb = 0.0;  ///< marker spacing along the height, dx
  Matrix3X position_lb;  ///< 3 x nx ny, dx, in the fluid's lattice frame
  Vector area_lb;       ///< dA_l of each marker (its cell), dx^2
};

/// What the library read from the scene and the command line.
struct COSIM_SDK_API Scene {
  std::string path;        ///< the scene file
  std::string name;        ///< [scene] name
  std::string output_dir;  ///< [output] directory, or --output
  int time_ratio = 0;      ///< A_T: substeps per LB step
  double dx_m = 0.0, dt_lb_s = 0.0, dt_cg_s = 0.0;  ///< dx, dt_LB, dt_CG = dt_LB / A_T
  double air_density_kg_m3 = 0.0, sound_speed_m_s = 0.0;
  std::vector<Sheet> sheets;
  /// All sheets' markers in one array, sheet by sheet: the default markers of a solid.
  Matrix3X position_lb;
  Vector area_lb;

  /// The value of `--NAME VALUE` given after the scene (e.g. --solid-cmd "my_solid
  /// --stiffness 0.1"), else `fallback`. An option no call asked for ends the run with exit
  /// code 2 ("unknown option"); a value that is not a number likewise.
  double param(const std::string& option, double fallback) const;

  std::map<std::string, std::string> params;  ///< as given, without the leading "--"
  mutable std::set<std::string> asked;        ///< the names param() was asked for
};

/// The markers a solid exchanges: positions (3 x N, dx) and surface elements (N, dx^2).
struct Markers {
  Matrix3X position_lb;
  Vector area_lb;
};

/// One LB step of the serial scheme (section 5): the fluid at the markers after the fluid's
/// step `step`, frozen over the A_T substeps the solid takes now.
struct Interval {
  std::int64_t step = 0;          ///< the LB step (1 .. N - 1)
  int substeps = 0;               ///< A_T
  Vector rho_lb;         ///< rho_l (N)
  Matrix3X velocity_lb;   ///< u_l (3 x N)
};

/// What the solid answers for one LB step.
struct Answer {
  /// X_l where the fluid spreads J_l: the markers' mean position over the step (e.g. the
  /// trapezoid mean of the substep boundaries), 3 x N, dx.
  Matrix3X position_lb;
  /// J_l, the impulse the solid gives the fluid over the step (Eq. 24): the mean over the
  /// A_T substeps of g_l dA_l, g_l = 2 rho_l (U_B - u_l) (momentum_exchange below), with U_B
  /// the marker's velocity in that substep; the marker itself receives -g_l dA_l. 3 x N.
  Matrix3X impulse_lb;
};

/// g dA for one marker: 2 rho (U_B - u) dA, the force the fluid receives (Eqs. 18-19); the
/// marker receives its opposite. Lattice units.
inline Eigen::Vector3d momentum_exchange(double rho, const Eigen::Vector3d& marker_velocity,
                                         const Eigen::Vector3d& fluid_velocity, double area) {
  return 2.0 * rho * area * (marker_velocity - fluid_velocity);
}

/// The interface a solid model implements.
class COSIM_SDK_API Solid {
 public:
  virtual ~Solid() = default;
  /// The name announced in hello_t ("model"), e.g. "spring-sheet".
  virtual std::string model() const = 0;
  /// The markers at the start of the run (called once, after the scene is read). The
  /// scene's markers (scene.position_lb, scene.area_lb) unless the solid has its own.
  virtual Markers start(const Scene& scene) = 0;
  /// One LB step: A_T substeps of dt = 1 / A_T (in dt_LB) with the sample frozen. An answer
  /// of the wrong size ends the run with exit code 3, as a non-finite one does (a
  /// std::length_error thrown here counts as such: the Python binding's, for an array of
  /// the wrong shape); any other exception with exit code 1.
  virtual Answer step(const Interval& in) = 0;
  /// The largest stable substep in seconds (hello_t; the fluid refuses a dt_CG above it);
  /// +infinity: no limit.
  virtual double stable_dt_cg_s() const { return std::numeric_limits<double>::infinity(); }
  /// Optional: the solid's mechanical energy (kinetic + elastic + whatever it stores) after
  /// its last step, in lattice units rho_air dx^3 c^2 (= rho_air dx^5 / dt_LB^2); NaN (the
  /// default): not reported. Called after start() and after every step(). When reported,
  /// the library writes it to OUTPUT/solid.h5 (total_energy_J) and checks the energy
  /// balance: the energy gained may not exceed the fluid's work on the markers by more than
  /// half the energy scale (protocol/README.md 15; a trip ends the run with exit code 3,
  /// naming the solid's energy and the work).
  virtual double energy_lb() const { return std::numeric_limits<double>::quiet_NaN(); }

  /// Optional checkpoints (DESIGN 2.4): the solid's whole state after its last step, as
  /// numbers. The library writes it with the fluid's, every [coupling] checkpoint_every LB
  /// steps and on a clean abort, into OUTPUT/checkpoints/solid_NNNNNNNN.h5 (with what the
  /// library itself keeps: the markers, the solid_state_t in flight, the seqs); empty (the
  /// default): none is written and --restart is refused.
  virtual std::vector<double> save() const { return {}; }
  /// Back to a state save() gave (launch/run-coupled.sh --restart DIR). Throw
  /// std::invalid_argument for a state that does not fit (exit code 2).
  virtual void restore(const std::vector<double>& /*state*/) {
    throw std::invalid_argument("this solid keeps no checkpoints (Solid::restore)");
  }
};

/// Runs `solid` as the solid peer of a coupled run and returns the exit code of
/// protocol/README.md section 9 (0 done, 1 system, 2 bad input or refused, 3 unhealthy:
/// a non-finite or mis-sized answer, 4 the fluid lost or stopped with an error).
///
/// Command line (the launcher's): SCENE [--output DIR] [--channel-prefix P] [--lcm-url U]
/// [--token T] [--time-ratio N] [--quiet] [--faults SPEC] [--NAME VALUE ...] (the token
/// defaults to $COSIM_RUN_TOKEN). Progress and the closing counters go to stdout, the reason
/// of a failure on one line to stderr. Exceptions thrown by the solid end the run with exit
/// code 1 (std::invalid_argument from start(): 2), after stop_t to the fluid.
COSIM_SDK_API int run(Solid& solid, int argc, const char* const* argv);
COSIM_SDK_API int run(Solid& solid, const std::vector<std::string>& args);

/// Benchmarks, without a fluid: a scene of one flat nx x ny sheet facing the stream (spacing
/// 1 dx, area 1 dx^2, one clamped row; the paper's units with A_T = `time_ratio`).
COSIM_SDK_API Scene synthetic_scene(int nx, int ny, int time_ratio);
/// Mean wall-clock seconds of solid.step() per LB step over `steps` steps in a uniform
/// stream (rho 1, u = (0.05, 0, 0)), after solid.start(scene).
COSIM_SDK_API double time_steps(Solid& solid, const Scene& scene, int steps);

}  // namespace cosim::sdk
