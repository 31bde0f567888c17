#include "tools/conformance/golden_trace.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "common/text/text.hpp"

namespace cosim::conformance {

namespace {

using Row = std::array<double, 8>;  // step, marker, x, y, z, jx, jy, jz

std::vector<Row> rows_of(const Trace& t) {
  std::vector<Row> rows;
  for (std::int64_t k = 0; k <= t.plan.last_step; ++k) {
    const cosimlcm::solid_state_t* m = t.state(k);
    if (m == nullptr) break;
    for (std::size_t l = 0; l < m->position_lb.size() && l < m->impulse_lb.size(); ++l) {
      if (m->position_lb[l].size() != 3 || m->impulse_lb[l].size() != 3) break;
      rows.push_back({double(k), double(l), m->position_lb[l][0], m->position_lb[l][1], m->position_lb[l][2],
                      m->impulse_lb[l][0], m->impulse_lb[l][1], m->impulse_lb[l][2]});
    }
  }
  return rows;
}

}  // namespace

void write_golden_trace(const std::string& path, const Trace& main) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write the golden trace " + path);
  out << "# cosim-conformance golden trace: the main session's solid_state_t (model '"
      << (main.hello ? main.hello->model : std::string("?")) << "'), lattice units\n";
  out << "step,marker,x_lb,y_lb,z_lb,jx_lb,jy_lb,jz_lb\n";
  for (const Row& r : rows_of(main)) {
    out << static_cast<long long>(r[0]) << "," << static_cast<long long>(r[1]);
    for (std::size_t k = 2; k < r.size(); ++k) out << "," << protocol::fmt("%.17g", r[k]);
    out << "\n";
  }
}

Verdict check_golden_trace(const std::string& path, const Trace& main, double tolerance) {
  const std::string name = "golden trace";
  std::ifstream in(path);
  if (!in) return {name, false, "cannot read " + path};
  std::vector<Row> golden;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 's') continue;
    std::istringstream s(line);
    Row r{};
    char comma = 0;
    for (std::size_t k = 0; k < r.size(); ++k)
      if (!(s >> r[k]) || (k + 1 < r.size() && !(s >> comma))) return {name, false, path + ": a malformed row: " + line};
    golden.push_back(r);
  }
  const std::vector<Row> now = rows_of(main);
  if (now.size() != golden.size())
    return {name, false, path + " has " + std::to_string(golden.size()) + " rows, the run " + std::to_string(now.size())};
  double j_max = 0.0;
  for (const Row& r : golden) j_max = std::max({j_max, std::abs(r[5]), std::abs(r[6]), std::abs(r[7])});
  double worst = 0.0;
  for (std::size_t i = 0; i < now.size(); ++i)
    for (std::size_t k = 2; k < 8; ++k) {
      const double allowed = k < 5 ? tolerance * (1.0 + std::abs(golden[i][k])) : tolerance * j_max;
      const double d = std::abs(now[i][k] - golden[i][k]);
      if (!(d <= allowed))
        return {name, false,
                "step " + std::to_string(static_cast<long long>(golden[i][0])) + ", marker " +
                    std::to_string(static_cast<long long>(golden[i][1])) + ", " + std::string(k < 5 ? "position" : "impulse") + "[" +
                    std::to_string((k - 2) % 3) + "]: " +
                    protocol::fmt("%.17g", now[i][k]) + " vs " + protocol::fmt("%.17g", golden[i][k]) + " in " + path +
                    " (tolerance " + protocol::fmt("%g", tolerance) + ")"};
      if (allowed > 0.0) worst = std::max(worst, d / allowed * tolerance);
    }
  return {name, true,
          std::to_string(now.size()) + " rows within " + protocol::fmt("%g", tolerance) + " of " + path +
              " (largest deviation " + protocol::fmt("%.2g", worst) + " of the scale)"};
}

}  // namespace cosim::conformance
