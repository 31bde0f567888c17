#include "tools/replay/compare.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <vector>

#include "common/text/text.hpp"

namespace cosim::replay {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Compares the values of one message, bit for bit, in message order and CGP by CGP, so
/// that the first difference is at the first CGP that differs.
class StepComparer {
 public:
  explicit StepComparer(StepResult& r) : r_(r) {}

  void value(double replay, double logged, const char* field, std::int64_t cgp = -1, int comp = -1) {
    ++r_.values;
    if (std::bit_cast<std::uint64_t>(replay) == std::bit_cast<std::uint64_t>(logged)) return;
    ++r_.differing;
    double abs = std::abs(replay - logged);
    if (std::isnan(abs)) abs = kInf;
    const double scale = std::max(std::abs(replay), std::abs(logged));
    const double rel = abs == 0.0 ? 0.0 : (scale > 0.0 && std::isfinite(scale) ? abs / scale : kInf);
    const auto make = [&] {
      FieldDiff d;
      d.field = field;
      // Appended piece by piece: GCC 12's -Wrestrict misreads "[" + std::to_string(k) here.
      for (const std::int64_t k : {cgp, std::int64_t(comp)})
        if (k >= 0) d.field.append(1, '[').append(std::to_string(k)).append(1, ']');
      d.cgp = cgp;
      d.replay = replay;
      d.logged = logged;
      d.abs = abs;
      d.rel = rel;
      return d;
    };
    if (!r_.first) r_.first = make();
    if (!r_.max_abs || abs > r_.max_abs->abs) r_.max_abs = make();
    if (!r_.max_rel || rel > r_.max_rel->rel) r_.max_rel = make();
  }

  /// The sizes of a per-CGP array (a difference is a field of the whole message).
  template <class A>
  void size(const A& replay, const A& logged, const char* field) {
    if (replay.size() == logged.size()) return;
    const std::string name = std::string("len(") + field + ")";
    value(double(replay.size()), double(logged.size()), name.c_str());
  }

  /// CGP l of a per-CGP array of numbers, or of [n][3] vectors (their sizes, then values).
  void at(const std::vector<double>& replay, const std::vector<double>& logged, std::size_t l, const char* field) {
    if (l < replay.size() && l < logged.size()) value(replay[l], logged[l], field, std::int64_t(l));
  }
  void at(const std::vector<std::vector<double>>& replay, const std::vector<std::vector<double>>& logged,
          std::size_t l, const char* field) {
    if (l >= replay.size() || l >= logged.size()) return;
    const std::size_t a = replay[l].size(), b = logged[l].size();
    if (a != b) {
      const std::string name = std::string("len(") + field + ")";
      value(double(a), double(b), name.c_str(), std::int64_t(l));
    }
    for (std::size_t c = 0; c < std::min(a, b); ++c)
      value(replay[l][c], logged[l][c], field, std::int64_t(l), int(c));
  }

 private:
  StepResult& r_;
};

/// The CGPs both copies of a per-CGP array have.
template <class A>
std::size_t both(const A& a, const A& b) {
  return std::min(a.size(), b.size());
}

}  // namespace

/// fluid_state_t (protocol/README.md section 3), the logged one of the same seq: step,
/// iteration, num_cgps, bulk_velocity_lb, then per CGP rho_lb, velocity_lb, rho_start_lb,
/// velocity_start_lb.
void compare(const cosimlcm::fluid_state_t& a, const cosimlcm::fluid_state_t& b, StepResult& r) {
  StepComparer c(r);
  c.value(double(a.step), double(b.step), "step");
  c.value(a.iteration, b.iteration, "iteration");
  c.value(a.num_cgps, b.num_cgps, "num_cgps");
  c.value(a.bulk_velocity_lb, b.bulk_velocity_lb, "bulk_velocity_lb");
  c.size(a.rho_lb, b.rho_lb, "rho_lb");
  c.size(a.velocity_lb, b.velocity_lb, "velocity_lb");
  c.size(a.rho_start_lb, b.rho_start_lb, "rho_start_lb");
  c.size(a.velocity_start_lb, b.velocity_start_lb, "velocity_start_lb");
  const std::size_t n = std::max({both(a.rho_lb, b.rho_lb), both(a.velocity_lb, b.velocity_lb),
                                   both(a.rho_start_lb, b.rho_start_lb),
                                   both(a.velocity_start_lb, b.velocity_start_lb)});
  for (std::size_t l = 0; l < n; ++l) {
    c.at(a.rho_lb, b.rho_lb, l, "rho_lb");
    c.at(a.velocity_lb, b.velocity_lb, l, "velocity_lb");
    c.at(a.rho_start_lb, b.rho_start_lb, l, "rho_start_lb");
    c.at(a.velocity_start_lb, b.velocity_start_lb, l, "velocity_start_lb");
  }
}

/// solid_state_t (section 3), the logged one of the same seq: step, iteration, substeps,
/// solid_time_s, num_cgps, then per CGP position_lb and impulse_lb.
void compare(const cosimlcm::solid_state_t& a, const cosimlcm::solid_state_t& b, StepResult& r) {
  StepComparer c(r);
  c.value(double(a.step), double(b.step), "step");
  c.value(a.iteration, b.iteration, "iteration");
  c.value(a.substeps, b.substeps, "substeps");
  c.value(a.solid_time_s, b.solid_time_s, "solid_time_s");
  c.value(a.num_cgps, b.num_cgps, "num_cgps");
  c.size(a.position_lb, b.position_lb, "position_lb");
  c.size(a.impulse_lb, b.impulse_lb, "impulse_lb");
  const std::size_t n = std::max(both(a.position_lb, b.position_lb), both(a.impulse_lb, b.impulse_lb));
  for (std::size_t l = 0; l < n; ++l) {
    c.at(a.position_lb, b.position_lb, l, "position_lb");
    c.at(a.impulse_lb, b.impulse_lb, l, "impulse_lb");
  }
}

/// What is compared, as the report names it.
const char* compared_fields(Side side) {
  return side == Side::Fluid ? "step, iteration, num_cgps, bulk_velocity_lb, rho_lb, velocity_lb, rho_start_lb, "
                               "velocity_start_lb"
                             : "step, iteration, substeps, solid_time_s, num_cgps, position_lb, impulse_lb";
}

std::string describe(const FieldDiff& d) {
  return d.field + ": replay " + protocol::fmt("%.17g", d.replay) + ", log " + protocol::fmt("%.17g", d.logged) +
         " (abs " + protocol::fmt("%.3g", d.abs) + ", rel " + protocol::fmt("%.3g", d.rel) + ")";
}

}  // namespace cosim::replay
