// The coordinator's per-step sentinels (DESIGN 6; common/watchdog/watchdog.hpp): on the markers of
// every solid_state_t (how far each CGP moved in one LB step, the distance to its nearest
// neighbour) and on the fluid's samples at the markers (density bounds, Mach number) before
// they are published. Cheap: O(markers) per step; the nearest neighbours are found once, on
// the first state. Transport-free, lattice units.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "common/watchdog/watchdog.hpp"

namespace cosim::protocol {

class MarkerWatch {
 public:
  using Vec3 = std::array<double, 3>;

  /// @param mach_limit  the fluid's run.mach_limit (|u| sqrt(3) at a marker above it trips)
  /// @param time_ratio  A_T, to report a displacement per substep
  MarkerWatch(const WatchdogSettings& settings, double mach_limit, int time_ratio);

  /// The markers X_l of solid_state_t(step) (finite: the coordinator checks that first).
  /// The first call takes the reference: each marker's nearest neighbour and their distance
  /// (a marker with no other within reach, or a single marker, has none); later calls check
  /// the displacement since the previous call and the neighbour distances.
  /// @post returns the first sentinel tripped (cgp_speed, then marker_spacing), in marker order
  std::optional<Trip> check_positions(std::int64_t step, const std::vector<Vec3>& x);

  /// The samples of fluid_state_t(step) at the markers last checked: the density the kernel
  /// sees (rho_l over the kernel's weight in the fluid) and u_l.
  /// @post returns marker_density (non-finite, or outside [rho_min, rho_max]) or marker_mach
  std::optional<Trip> check_samples(std::int64_t step, const std::vector<double>& rho,
                                    const std::vector<Vec3>& u) const;

  /// What a checkpoint keeps so that a restart watches exactly as the run would have: the
  /// neighbours (-1 for none), their first distances and the last markers checked.
  struct Reference {
    std::vector<std::int64_t> neighbour;
    std::vector<double> distance;
    std::vector<double> last_positions;  ///< 3 per marker
  };
  bool has_reference() const { return !neighbour_.empty(); }

  /// The extremes the sentinels saw so far (how close a healthy run came to each limit),
  /// one line: "CGP speed max ... c (limit ...), marker spacing ratio [..., ...] (limits ...),
  /// marker rho [..., ...] (limits ...), marker Mach max ... (limit ...)".
  std::string margins() const;
  Reference reference() const;
  /// @throws std::invalid_argument when the sizes do not agree
  void restore(const Reference& r);

 private:
  WatchdogSettings s_;
  double mach_limit_;
  int time_ratio_;
  std::vector<std::int64_t> neighbour_;
  std::vector<double> distance_;
  std::vector<Vec3> last_;
  // The extremes seen (margins()).
  double max_speed_ = 0.0, min_ratio_ = 1.0, max_ratio_ = 1.0;
  mutable double min_rho_ = 1.0, max_rho_ = 1.0, max_mach_ = 0.0;
};

}  // namespace cosim::protocol
