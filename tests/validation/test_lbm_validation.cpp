// Validation of the bulk LBM against analytic solutions (validation-references.md):
// body-force Poiseuille flow between half-way bounce-back walls, and the decay of a 2D
// Taylor-Green vortex in a 3D periodic box.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"

namespace {

using namespace cosim::fluid;

/// Relative L2 error of steady body-force Poiseuille flow across a channel of ny cells,
/// walls (half-way bounce-back) at y = -1/2 and ny - 1/2, against
/// u(y) = G y' (H - y') / (2 nu), y' = y + 1/2, H = ny.
double poiseuille_error(int ny, double tau) {
  FluidParams p;
  p.shape = {4, ny, 4};
  p.tau = tau;
  p.faces[YMin].kind = FaceKind::Wall;
  p.faces[YMax].kind = FaceKind::Wall;
  const double nu = (tau - 0.5) / 3.0, H = ny, u_max = 0.01;
  const double G = 8.0 * nu * u_max / (H * H);
  p.body_force = {G, 0.0, 0.0};
  FluidSolver s(p);
  // Run to steady state: the slowest mode decays as exp(-nu pi^2 t / H^2).
  const int steps = int(std::ceil(40.0 * H * H / (nu * std::numbers::pi * std::numbers::pi)));
  for (int n = 0; n < steps; ++n) s.step();
  double num = 0, den = 0;
  for (int y = 0; y < ny; ++y) {
    const double yp = y + 0.5;
    const double exact = G * yp * (H - yp) / (2.0 * nu);
    const double u = s.cell(1, y, 1).ux;
    num += (u - exact) * (u - exact);
    den += exact * exact;
  }
  return std::sqrt(num / den);
}

TEST(Validation, PoiseuilleConvergesSecondOrder) {
  const double tau = 0.8;  // away from the magic value 1/2 + sqrt(3/16) where HWBB is exact
  const int res[3] = {8, 16, 32};
  double err[3];
  for (int i = 0; i < 3; ++i) err[i] = poiseuille_error(res[i], tau);
  for (int i = 0; i < 2; ++i) {
    const double order = std::log(err[i] / err[i + 1]) / std::log(2.0);
    RecordProperty("order_" + std::to_string(res[i]) + "_" + std::to_string(res[i + 1]),
                   std::to_string(order));
    std::printf("Poiseuille ny=%d err=%.3e -> ny=%d err=%.3e: order %.3f\n", res[i], err[i],
                res[i + 1], err[i + 1], order);
    EXPECT_GE(order, 1.8);
    EXPECT_LE(order, 2.2);
  }
}

TEST(Validation, TaylorGreenDecayRate) {
  const int N = 64;
  const double tau = 0.8, U = 0.02, nu = (tau - 0.5) / 3.0;
  const double k = 2.0 * std::numbers::pi / N;
  FluidParams p;
  p.shape = {N, N, 4};
  p.tau = tau;
  FluidSolver s(p);
  // u = U (-cos kx sin ky, sin kx cos ky, 0), p = -rho U^2 / 4 (cos 2kx + cos 2ky).
  s.initialize([&](int x, int y, int) {
    const double pr = -0.25 * U * U * (std::cos(2 * k * x) + std::cos(2 * k * y));
    return CellState{1.0 + 3.0 * pr, -U * std::cos(k * x) * std::sin(k * y),
                     U * std::sin(k * x) * std::cos(k * y), 0.0};
  });
  // Amplitude: projection of u_x on the mode shape.
  auto amplitude = [&] {
    MacroscopicFields m;
    s.macroscopic(m);
    double num = 0, den = 0;
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        const double shape = -std::cos(k * x) * std::sin(k * y);
        num += m.ux[m.index(x, y, 1)] * shape;
        den += shape * shape;
      }
    return num / den;
  };
  for (int n = 0; n < 50; ++n) s.step();  // let the initial pressure transient pass
  const double a1 = amplitude();
  const int span = 500;
  for (int n = 0; n < span; ++n) s.step();
  const double a2 = amplitude();
  const double rate = -std::log(a2 / a1) / span;
  const double expected = 2.0 * nu * k * k;
  std::printf("Taylor-Green N=%d: decay rate %.6e, 2 nu k^2 = %.6e, rel. error %.2e\n", N, rate,
              expected, std::abs(rate - expected) / expected);
  EXPECT_LT(std::abs(rate - expected) / expected, 0.01);
}

}  // namespace
