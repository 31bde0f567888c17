#include "fluid/collision/kernel_dispatch.hpp"

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>

#if defined(__x86_64__)
#include <cpuid.h>
#endif

#include "fluid/lattice/d3q19.hpp"

// Each level's translation unit defines its table in a namespace of its own.
#define COSIM_DECLARE_TABLE(ns, name) \
  namespace cosim::fluid::isa_##ns {  \
  extern const KernelTable kernel_table; \
  }
COSIM_FOR_EACH_ISA_LEVEL(COSIM_DECLARE_TABLE)
#undef COSIM_DECLARE_TABLE

namespace cosim::fluid {

namespace {

#define COSIM_TABLE_ADDRESS(ns, name) &isa_##ns::kernel_table,
const KernelTable* const kTables[] = {COSIM_FOR_EACH_ISA_LEVEL(COSIM_TABLE_ADDRESS)};
#undef COSIM_TABLE_ADDRESS
constexpr int kLevels = int(sizeof kTables / sizeof kTables[0]);

bool runs(int level) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  const std::string name = kTables[level]->level;
  // The micro-architecture levels of the x86-64 psABI; the checks include the operating
  // system's support for the wider registers (XCR0).
  const bool v2 = __builtin_cpu_supports("ssse3") && __builtin_cpu_supports("sse4.1") &&
                  __builtin_cpu_supports("sse4.2") && __builtin_cpu_supports("popcnt");
  const bool v3 = v2 && __builtin_cpu_supports("avx") && __builtin_cpu_supports("avx2") &&
                  __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
                  __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("f16c");
  const bool v4 = v3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                  __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                  __builtin_cpu_supports("avx512vl");
  if (name == "x86-64-v2") return v2;
  if (name == "x86-64-v3") return v3;
  if (name == "x86-64-v4") return v4;
  return false;
#else
  (void)level;
  return true;
#endif
}

std::string allowed_levels() {
  std::string s;
  for (int i = 0; i < kLevels; ++i) {
    if (!runs(i)) continue;
    s += (s.empty() ? "" : ", ");
    s += kTables[i]->level;
  }
  return s;
}

/// The index of a level by name. @throws std::invalid_argument naming `what`
int level_index(const std::string& level, const char* what) {
  for (int i = 0; i < kLevels; ++i) {
    if (level != kTables[i]->level) continue;
    if (!runs(i))
      throw std::invalid_argument(std::string(what) + " = '" + level + "': this CPU (" + cpu_model() +
                                  ") cannot run that level; it runs " + allowed_levels());
    return i;
  }
  throw std::invalid_argument(std::string(what) + " = '" + level +
                              "' is not a kernel level of this binary; allowed: " + allowed_levels());
}

const char* g_source = "CPU features";

int initial_level() {
  if (const char* env = std::getenv("COSIM_KERNEL_LEVEL"); env != nullptr && *env != '\0') {
    const int i = level_index(env, "COSIM_KERNEL_LEVEL");
    g_source = "COSIM_KERNEL_LEVEL";
    return i;
  }
  int best = 0;
  for (int i = 0; i < kLevels; ++i)
    if (runs(i)) best = i;
  return best;
}

std::atomic<int>& active() {
  static std::atomic<int> index{initial_level()};
  return index;
}

}  // namespace

std::vector<std::string> kernel_levels() {
  std::vector<std::string> names;
  for (const KernelTable* t : kTables) names.emplace_back(t->level);
  return names;
}

bool cpu_runs_level(const std::string& level) {
  for (int i = 0; i < kLevels; ++i)
    if (level == kTables[i]->level) return runs(i);
  return false;
}

const KernelTable& active_kernel() { return *kTables[active().load(std::memory_order_relaxed)]; }
int active_kernel_index() { return active().load(std::memory_order_relaxed); }

void set_kernel_level(const std::string& level, const char* source) {
  const int i = level_index(level, source);
  active().store(i);
  g_source = source;
}

const char* kernel_level_source() {
  active();
  return g_source;
}

std::string cpu_model() {
#if defined(__x86_64__)
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (__get_cpuid(0x80000000u, &a, &b, &c, &d) == 0 || a < 0x80000004u) return "unknown";
  char brand[49] = {};
  for (unsigned leaf = 0; leaf < 3; ++leaf) {
    __get_cpuid(0x80000002u + leaf, &a, &b, &c, &d);
    const unsigned regs[4] = {a, b, c, d};
    std::memcpy(brand + 16 * leaf, regs, 16);
  }
  std::string s(brand);
  const auto first = s.find_first_not_of(' ');
  const auto last = s.find_last_not_of(' ');
  return first == std::string::npos ? "unknown" : s.substr(first, last - first + 1);
#else
  return "unknown";
#endif
}

namespace {

/// The size of the L3 cache that CPU 0 sees, from the kernel's cache description (sysfs, as
/// lscpu reads it: "32768K"); 0 where there is none. Not sysconf(_SC_LEVEL3_CACHE_SIZE):
/// glibc's CPUID reading gave 384 MiB in a 2-core AMD EPYC VM whose L3 is 32 MiB.
std::size_t l3_cache_bytes() {
  for (int index = 0; index < 8; ++index) {
    const std::string dir = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(index) + "/";
    std::ifstream level(dir + "level"), size(dir + "size");
    int l = 0;
    std::string text;
    if (!(level >> l) || l != 3 || !(size >> text)) continue;
    char* end = nullptr;
    const unsigned long long n = std::strtoull(text.c_str(), &end, 10);
    const std::size_t unit = *end == 'K' ? 1024 : *end == 'M' ? 1024 * 1024 : *end == '\0' ? 1 : 0;
    return std::size_t(n) * unit;
  }
  return 0;
}

}  // namespace

std::size_t streaming_stores_from() {
  static const std::size_t from = [] {
    const std::size_t l3 = l3_cache_bytes();
    return l3 > 0 ? l3 : kStreamingStoresFrom;
  }();
  return from;
}

bool uses_streaming_stores(const GridLayout& layout, Stores stores, std::size_t value_bytes) {
  if (!active_kernel().streaming_stores || stores == Stores::Cached) return false;
  return stores == Stores::Streaming ||
         D3Q19::Q * layout.stride() * value_bytes >= streaming_stores_from();
}

namespace {

[[noreturn]] void no_float_arithmetic(const char* call) {
  throw std::invalid_argument(std::string(call) + ": float arithmetic needs the float store (precision \"single\")");
}

[[noreturn]] void no_double_arithmetic(const char* call) {
  throw std::invalid_argument(std::string(call) + ": the half store computes in float only (precision \"half\")");
}

}  // namespace

void stream_collide(const PopulationField& src, PopulationField& dst, double tau,
                    const std::array<double, 3>& force, Stores stores, const KernelOutflow& outflow,
                    KernelExtrema* extrema, RowSchedule schedule, Arithmetic arithmetic) {
  if (arithmetic != Arithmetic::Double) no_float_arithmetic("stream_collide");
  active_kernel().run_double(src, dst, tau, force, uses_streaming_stores(src.layout(), stores, sizeof(double)),
                             outflow, extrema, schedule);
}

void stream_collide(const PopulationFieldSingle& src, PopulationFieldSingle& dst, double tau,
                    const std::array<double, 3>& force, Stores stores, const KernelOutflow& outflow,
                    KernelExtrema* extrema, RowSchedule schedule, Arithmetic arithmetic) {
  const KernelTable& k = active_kernel();
  (arithmetic == Arithmetic::Float ? k.run_single : k.run_mixed)(
      src, dst, tau, force, uses_streaming_stores(src.layout(), stores, sizeof(float)), outflow, extrema, schedule);
}

void stream_collide_in_place(PopulationField& f, PopulationLayout layout, double tau,
                             const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                             const InPlaceXFaces* x_faces, Arithmetic arithmetic, KernelRows rows) {
  if (arithmetic != Arithmetic::Double) no_float_arithmetic("stream_collide_in_place");
  active_kernel().in_place_double(f, layout == PopulationLayout::Canonical, tau, force, extrema, schedule,
                                  x_faces != nullptr && x_faces->all() ? x_faces : nullptr, rows);
}

void stream_collide_in_place(PopulationFieldSingle& f, PopulationLayout layout, double tau,
                             const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                             const InPlaceXFaces* x_faces, Arithmetic arithmetic, KernelRows rows) {
  const KernelTable& k = active_kernel();
  (arithmetic == Arithmetic::Float ? k.in_place_single : k.in_place_mixed)(
      f, layout == PopulationLayout::Canonical, tau, force, extrema, schedule,
      x_faces != nullptr && x_faces->all() ? x_faces : nullptr, rows);
}

void stream_collide(const PopulationFieldHalf& src, PopulationFieldHalf& dst, double tau,
                    const std::array<double, 3>& force, Stores stores, const KernelOutflow& outflow,
                    KernelExtrema* extrema, RowSchedule schedule, Arithmetic arithmetic) {
  if (arithmetic != Arithmetic::Float) no_double_arithmetic("stream_collide");
  active_kernel().run_half(src, dst, tau, force, uses_streaming_stores(src.layout(), stores, sizeof(Half16)), outflow,
                           extrema, schedule);
}

void stream_collide_in_place(PopulationFieldHalf& f, PopulationLayout layout, double tau,
                             const std::array<double, 3>& force, KernelExtrema* extrema, RowSchedule schedule,
                             const InPlaceXFaces* x_faces, Arithmetic arithmetic, KernelRows rows) {
  if (arithmetic != Arithmetic::Float) no_double_arithmetic("stream_collide_in_place");
  active_kernel().in_place_half(f, layout == PopulationLayout::Canonical, tau, force, extrema, schedule,
                                x_faces != nullptr && x_faces->all() ? x_faces : nullptr, rows);
}

}  // namespace cosim::fluid
