#include "fluid/watchdog/marker_watch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/text/text.hpp"

namespace cosim::protocol {

namespace {

double distance(const MarkerWatch::Vec3& a, const MarkerWatch::Vec3& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

std::string at(const MarkerWatch::Vec3& x) {
  std::string s(1, '(');  // not "(" + ...: GCC 12 warns falsely (-Wrestrict)
  s += fmt("%.4g", x[0]) + ", " + fmt("%.4g", x[1]) + ", " + fmt("%.4g", x[2]) + ")";
  return s;
}

std::string head(const char* sentinel, std::int64_t step) {
  return std::string("watchdog ") + sentinel + " at step " + std::to_string(step) + ": ";
}

}  // namespace

MarkerWatch::MarkerWatch(const WatchdogSettings& settings, double mach_limit, int time_ratio)
    : s_(settings), mach_limit_(mach_limit), time_ratio_(time_ratio < 1 ? 1 : time_ratio) {}

std::optional<Trip> MarkerWatch::check_positions(std::int64_t step, const std::vector<Vec3>& x) {
  const std::size_t n = x.size();
  if (neighbour_.empty() || last_.size() != n) {
    // The reference: O(n^2) once. A neighbour further than 4 dx is not a neighbour on the
    // sheet (a lone marker), and is not watched.
    neighbour_.assign(n, -1);
    distance_.assign(n, 0.0);
    for (std::size_t l = 0; l < n; ++l) {
      double best = 4.0;
      for (std::size_t k = 0; k < n; ++k) {
        if (k == l) continue;
        const double d = distance(x[l], x[k]);
        if (d > 0.0 && d < best) best = d, neighbour_[l] = static_cast<std::int64_t>(k);
      }
      if (neighbour_[l] >= 0) distance_[l] = best;
    }
    last_ = x;
    return std::nullopt;
  }
  // cgp_speed: the mean position moved |dX| in one LB step, i.e. at |dX| c.
  for (std::size_t l = 0; l < n; ++l) {
    const double d = distance(x[l], last_[l]);
    if (d > max_speed_) max_speed_ = d;
    if (!(d <= s_.max_cgp_speed)) {
      Trip t;
      t.sentinel = "cgp_speed";
      t.step = step;
      t.dt_cure = true;
      t.measurement = head("cgp_speed", step) + "CGP " + std::to_string(l) + " at " + at(x[l]) +
                      " moved " + fmt("%.4g", d) + " dx in one LB step (" + fmt("%.4g", d / time_ratio_) +
                      " dx per substep at A_T = " + std::to_string(time_ratio_) + "; speed " +
                      fmt("%.4g", d) + " c = Mach " + fmt("%.3g", d * std::sqrt(3.0)) +
                      "), above watchdog.max_cgp_speed = " + fmt("%.4g", s_.max_cgp_speed) + " c";
      t.diagnosis = t.measurement +
                    "; a solid integration that diverges (a smaller dt_CG may cure it) or a "
                    "flow faster than the lattice allows";
      return t;
    }
  }
  // marker_spacing: each marker and its first nearest neighbour.
  for (std::size_t l = 0; l < n; ++l) {
    const std::int64_t k = neighbour_[l];
    if (k < 0) continue;
    const double d = distance(x[l], x[static_cast<std::size_t>(k)]);
    const double ratio = d / distance_[l];
    min_ratio_ = std::min(min_ratio_, ratio);
    max_ratio_ = std::max(max_ratio_, ratio);
    if (!(ratio >= s_.spacing_ratio_min && ratio <= s_.spacing_ratio_max)) {
      Trip t;
      t.sentinel = "marker_spacing";
      t.step = step;
      t.diagnosis = head("marker_spacing", step) + "CGPs " + std::to_string(l) + " at " + at(x[l]) +
                    " and " + std::to_string(k) + " at " + at(x[static_cast<std::size_t>(k)]) +
                    " are " + fmt("%.4g", d) + " dx apart, " + fmt("%.4g", ratio) +
                    " of their first distance " + fmt("%.4g", distance_[l]) + " dx, outside [" +
                    fmt("%.4g", s_.spacing_ratio_min) + ", " + fmt("%.4g", s_.spacing_ratio_max) +
                    "] (watchdog.spacing_ratio_min, _max): the sheet " +
                    (ratio < s_.spacing_ratio_min ? "folds onto itself" : "tears apart") +
                    "; the immersed boundary no longer holds the fluid between its markers";
      return t;
    }
  }
  last_ = x;
  return std::nullopt;
}

std::optional<Trip> MarkerWatch::check_samples(std::int64_t step, const std::vector<double>& rho,
                                               const std::vector<Vec3>& u) const {
  for (std::size_t l = 0; l < rho.size() && l < u.size(); ++l) {
    const std::string where = "the fluid at CGP " + std::to_string(l) +
                              (l < last_.size() ? " at " + at(last_[l]) : std::string());
    const bool finite = std::isfinite(rho[l]) && std::isfinite(u[l][0]) && std::isfinite(u[l][1]) &&
                        std::isfinite(u[l][2]);
    if (finite) {
      min_rho_ = std::min(min_rho_, rho[l]);
      max_rho_ = std::max(max_rho_, rho[l]);
      max_mach_ = std::max(max_mach_, std::hypot(u[l][0], u[l][1], u[l][2]) * std::sqrt(3.0));
    }
    if (!finite || !(rho[l] >= s_.rho_min && rho[l] <= s_.rho_max)) {
      Trip t;
      t.sentinel = "marker_density";
      t.step = step;
      t.measurement = head("marker_density", step) + where + ": " +
                      (finite ? "rho = " + fmt("%.6g", rho[l]) + " outside [" + fmt("%.4g", s_.rho_min) +
                                    ", " + fmt("%.4g", s_.rho_max) + "] (watchdog.rho_min, rho_max)"
                              : std::string("rho or u is not finite"));
      t.diagnosis = t.measurement +
                    "; the lattice's weak compressibility is gone there (a slower flow, a larger "
                    "tau, or a finer grid)";
      return t;
    }
    const double speed = std::hypot(u[l][0], u[l][1], u[l][2]);
    const double mach = speed * std::sqrt(3.0);
    if (mach > mach_limit_) {
      Trip t;
      t.sentinel = "marker_mach";
      t.step = step;
      t.measurement = head("marker_mach", step) + where + ": |u| = " + fmt("%.4g", speed) + " c, Mach " +
                      fmt("%.4g", mach) + " above run.mach_limit = " + fmt("%.4g", mach_limit_);
      t.diagnosis = t.measurement + " (a slower inlet or a finer grid)";
      return t;
    }
  }
  return std::nullopt;
}

std::string MarkerWatch::margins() const {
  return "CGP speed max " + fmt("%.3g", max_speed_) + " c (limit " + fmt("%g", s_.max_cgp_speed) +
         "), marker spacing ratio [" + fmt("%.4g", min_ratio_) + ", " + fmt("%.4g", max_ratio_) + "] (limits [" +
         fmt("%g", s_.spacing_ratio_min) + ", " + fmt("%g", s_.spacing_ratio_max) + "]), marker rho [" +
         fmt("%.5g", min_rho_) + ", " + fmt("%.5g", max_rho_) + "] (limits [" + fmt("%g", s_.rho_min) + ", " +
         fmt("%g", s_.rho_max) + "]), marker Mach max " + fmt("%.3g", max_mach_) + " (limit " +
         fmt("%g", mach_limit_) + ")";
}

MarkerWatch::Reference MarkerWatch::reference() const {
  Reference r;
  r.neighbour = neighbour_;
  r.distance = distance_;
  for (const Vec3& x : last_)
    for (const double v : x) r.last_positions.push_back(v);
  return r;
}

void MarkerWatch::restore(const Reference& r) {
  if (r.distance.size() != r.neighbour.size() || r.last_positions.size() != 3 * r.neighbour.size())
    throw std::invalid_argument("the watchdog's reference has inconsistent sizes (" +
                                std::to_string(r.neighbour.size()) + " neighbours, " +
                                std::to_string(r.distance.size()) + " distances, " +
                                std::to_string(r.last_positions.size()) + " coordinates)");
  for (const std::int64_t k : r.neighbour)
    if (k < -1 || k >= static_cast<std::int64_t>(r.neighbour.size()))
      throw std::invalid_argument("the watchdog's reference names neighbour " + std::to_string(k) +
                                  " of " + std::to_string(r.neighbour.size()) + " markers");
  neighbour_ = r.neighbour;
  distance_ = r.distance;
  last_.assign(r.neighbour.size(), Vec3{});
  for (std::size_t l = 0; l < last_.size(); ++l)
    for (std::size_t c = 0; c < 3; ++c) last_[l][c] = r.last_positions[3 * l + c];
}

}  // namespace cosim::protocol
