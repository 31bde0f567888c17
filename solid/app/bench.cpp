// Time per CGP substep of the solid models (DESIGN 7): one sheet (200 CGPs) and a pair
// (400 CGPs, with the Lennard-Jones contact), the paper's 5 x 40 sheets, at the paper's
// dt_CG under a constant external load. Prints a table; medians of several repeats, of the
// wall clock and of this thread's CPU time.
//   solid_bench [--substeps N] [--repeat R] [--models rcgp corotational]
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/text/cli_parse.hpp"
#include "protocol/units.hpp"
#include "solid/model/model_registry.hpp"

namespace {

using namespace cosim::solid;

/// CPU time of this thread, s: unlike the wall clock it does not count the time the
/// scheduler gives other jobs on a shared machine.
double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Time per substep of the solid models"};
  int substeps = 20000, repeat = 5;
  std::vector<std::string> models{"rcgp", "corotational"};
  app.add_option("--substeps", substeps, "substeps per repeat")->check(CLI::PositiveNumber);
  app.add_option("--repeat", repeat, "repeats (the median is reported)")->check(CLI::PositiveNumber);
  app.add_option("--models", models, "registered model names");
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, "solid_bench")) return *code;

  const double dt = cosim::protocol::UnitConverter{}.dt_cg_s() /
                    cosim::protocol::PhysicalConstants::time_au_s;
  std::printf("%-14s %6s %5s %10s %12s %12s %14s\n", "model", "sheets", "CGPs", "substeps",
              "us/substep", "ns/CGP", "cpu us/substep");
  for (const std::string& name : models) {
    for (const int sheets : {1, 2}) {
      SolidConfig config;
      SheetSpec g1;
      g1.theta_deg = sheets == 1 ? 90.0 : 0.0;
      config.sheets = {g1};
      if (sheets == 2) {
        SheetSpec g2 = g1;
        g2.base_bohr = {0.0, 0.0, 4.0 * g1.width_spacing_bohr};  // the paper's ds = 1.02 um
        config.sheets.push_back(g2);
      }
      auto model = make_solid_model(name, config);
      // A small steady load along x, like a weak drag.
      const Eigen::Matrix3Xd load =
          Eigen::Matrix3Xd::Constant(3, model->num_cgps(), 1e-9).cwiseProduct(
              Eigen::Vector3d(1.0, 0.0, 0.0).replicate(1, model->num_cgps()));
      for (int k = 0; k < substeps / 10; ++k) model->substep(dt, load);  // warm up
      std::vector<double> us, cpu_us;
      for (int r = 0; r < repeat; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = thread_cpu_s();
        for (int k = 0; k < substeps; ++k) model->substep(dt, load);
        const double c = thread_cpu_s() - c0;
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        us.push_back(1e6 * s / substeps);
        cpu_us.push_back(1e6 * c / substeps);
      }
      const double t = median(us);
      std::printf("%-14s %6d %5ld %10d %12.2f %12.1f %14.2f\n", name.c_str(), sheets,
                  static_cast<long>(model->num_cgps()), substeps, t,
                  1e3 * t / static_cast<double>(model->num_cgps()), median(cpu_us));
    }
  }
  return 0;
}
