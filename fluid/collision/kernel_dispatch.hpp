// The fluid kernel chosen at run time by the CPU's features: one binary for every x86-64
// CPU. The kernel's sources (fluid/collision/stream_collide.cpp) are compiled once per instruction-set
// level (fluid/CMakeLists.txt, cosim_isa_objects), each into a namespace of its own; at the
// first step the highest level the CPU runs is chosen, or the one that COSIM_KERNEL_LEVEL
// (or set_kernel_level, e.g. the bench's --level) asks for.
//
// Every level gives the same bits, in each precision mode: the levels differ only in vector
// width (2, 4 or 8 doubles, or 4, 8 or 16 floats, per group), the arithmetic is elementwise, and their sources are compiled with
// -ffp-contract=off, so no level fuses a multiply and an add that another rounds twice
// (test_kernel_dispatch: KernelDispatchCoversEveryLevel). The half store's conversions
// (F16C on v3 and v4, portable code on the baseline) round alike (fluid/lattice/half.hpp).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "fluid/lattice/population_field.hpp"
#include "fluid/collision/stream_collide.hpp"

namespace cosim::fluid {

// The levels built into the binary, lowest first: X(namespace suffix, name). Kept in step
// with COSIM_ISA_LEVELS in fluid/CMakeLists.txt.
#if defined(__x86_64__)
#define COSIM_FOR_EACH_ISA_LEVEL(X) \
  X(x86_64_v2, "x86-64-v2")         \
  X(x86_64_v3, "x86-64-v3")         \
  X(x86_64_v4, "x86-64-v4")
#else
#define COSIM_FOR_EACH_ISA_LEVEL(X) X(generic, "generic")
#endif

/// What one level's translation unit of the kernel provides: the kernel for each store and
/// arithmetic (fluid/lattice/population_field.hpp, Precision): double store and arithmetic
/// ("double"), float store in double arithmetic ("mixed"), float store in float arithmetic
/// ("single"), 16-bit store in float arithmetic ("half").
struct KernelTable {
  const char* level;    ///< "x86-64-v3", ...
  const char* vectors;  ///< "AVX2, 4 doubles per group", ...
  int lanes;            ///< doubles per group (fluid/lattice/lanes.hpp, kLanes); floats: twice as many
  bool streaming_stores;
  void (*run_double)(const PopulationField& src, PopulationField& dst, double tau,
                     const std::array<double, 3>& force, bool streaming, const KernelOutflow& outflow,
                     KernelExtrema* extrema, RowSchedule schedule);
  void (*run_mixed)(const PopulationFieldSingle& src, PopulationFieldSingle& dst, double tau,
                    const std::array<double, 3>& force, bool streaming, const KernelOutflow& outflow,
                    KernelExtrema* extrema, RowSchedule schedule);
  void (*run_single)(const PopulationFieldSingle& src, PopulationFieldSingle& dst, double tau,
                     const std::array<double, 3>& force, bool streaming, const KernelOutflow& outflow,
                     KernelExtrema* extrema, RowSchedule schedule);
  void (*run_half)(const PopulationFieldHalf& src, PopulationFieldHalf& dst, double tau,
                   const std::array<double, 3>& force, bool streaming, const KernelOutflow& outflow,
                   KernelExtrema* extrema, RowSchedule schedule);
  /// stream_collide_in_place; from_canonical: the state is in PopulationLayout::Canonical.
  void (*in_place_double)(PopulationField& f, bool from_canonical, double tau,
                          const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                          const InPlaceXFaces* x_faces, KernelRows rows);
  void (*in_place_mixed)(PopulationFieldSingle& f, bool from_canonical, double tau,
                         const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                         const InPlaceXFaces* x_faces, KernelRows rows);
  void (*in_place_single)(PopulationFieldSingle& f, bool from_canonical, double tau,
                          const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                          const InPlaceXFaces* x_faces, KernelRows rows);
  void (*in_place_half)(PopulationFieldHalf& f, bool from_canonical, double tau,
                        const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                        const InPlaceXFaces* x_faces, KernelRows rows);
};

/// The names of the levels built into the binary, lowest first.
std::vector<std::string> kernel_levels();
/// Whether this CPU (and its operating system) runs the level's instructions.
bool cpu_runs_level(const std::string& level);
/// The table of the active level: on the first call, COSIM_KERNEL_LEVEL if set, else the
/// highest level the CPU runs. @throws std::invalid_argument (one line naming the variable,
/// its value and what is allowed) for an unknown level or one this CPU cannot run.
const KernelTable& active_kernel();
/// Its index in kernel_levels().
int active_kernel_index();
/// Makes `level` the active one from the next kernel call (tests, the bench's --level);
/// `source` names who asked, in errors and kernel_level_source(). Not while a kernel runs.
/// @throws std::invalid_argument as active_kernel()
void set_kernel_level(const std::string& level, const char* source = "set_kernel_level");
/// How the active level was chosen: "CPU features", "COSIM_KERNEL_LEVEL" or set_kernel_level's source.
const char* kernel_level_source();
/// The CPU's model name (CPUID brand string), or "unknown".
std::string cpu_model();

}  // namespace cosim::fluid
