#include "solid/coupling/fluid_state_check.hpp"

#include <cmath>
#include <iterator>
#include <string>

#include "common/text/text.hpp"

namespace cosim::solid {

namespace exit_code = protocol::exit_code;
using protocol::Ending;
using protocol::fmt;

std::optional<Ending> check_fluid_state(const cosimlcm::fluid_state_t& m, Eigen::Index num_cgps, std::int64_t final_step,
                                        std::int64_t total_steps, const SolidConfig& config) {
  const std::string where = "fluid_state_t of step " + std::to_string(m.step) + ": ";
  const auto malformed = [&](const std::string& what) {
    return Ending{exit_code::bad_input, where + what, true};
  };
  if (m.step > final_step)
    return malformed("the run has total_steps = " + std::to_string(total_steps) +
                     " (welcome_t); the last fluid_state_t is for step " +
                     std::to_string(total_steps - 1));
  if (m.num_cgps != num_cgps)
    return malformed("num_cgps = " + std::to_string(m.num_cgps) + ", expected " +
                     std::to_string(num_cgps) + " (the solid's hello_t)");
  if (std::ssize(m.rho_lb) != num_cgps || std::ssize(m.velocity_lb) != num_cgps)
    return malformed("rho_lb has " + std::to_string(m.rho_lb.size()) + " and velocity_lb " +
                     std::to_string(m.velocity_lb.size()) + " entries, expected " +
                     std::to_string(num_cgps));
  for (std::size_t l = 0; l < m.velocity_lb.size(); ++l)
    if (m.velocity_lb[l].size() != 3)
      return malformed("velocity_lb[" + std::to_string(l) + "] has " +
                       std::to_string(m.velocity_lb[l].size()) + " components, expected 3");
  if (!std::isfinite(m.bulk_velocity_lb))
    return Ending{exit_code::unhealthy,
                  where + "bulk_velocity_lb = " + fmt("%g", m.bulk_velocity_lb) + " is not finite",
                  true};
  for (std::size_t l = 0; l < m.rho_lb.size(); ++l) {
    const auto unhealthy = [&](const std::string& what) {
      return Ending{exit_code::unhealthy,
                    where + describe_cgp(config, static_cast<Eigen::Index>(l)) + ": " + what,
                    true};
    };
    if (!std::isfinite(m.rho_lb[l]))
      return unhealthy("rho_lb = " + fmt("%g", m.rho_lb[l]) + " is not finite");
    if (!(m.rho_lb[l] > 0.0))
      return unhealthy("rho_lb = " + fmt("%g", m.rho_lb[l]) + "; the density must be > 0");
    for (std::size_t c = 0; c < 3; ++c)
      if (!std::isfinite(m.velocity_lb[l][c]))
        return unhealthy("velocity_lb[" + std::to_string(c) + "] = " +
                         fmt("%g", m.velocity_lb[l][c]) + " is not finite");
  }
  return std::nullopt;
}

}  // namespace cosim::solid
