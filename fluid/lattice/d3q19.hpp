// D3Q19 velocity set (Fig. 2 of the paper) with the weights E_alpha of Eq. 12.
#pragma once

#include <array>

namespace cosim::fluid {

/// The lattice as a compile-time type. Ordering: 0 rest, 1-6 the axis directions
/// (E = 1/18), 7-18 the face diagonals (E = 1/36), as Eq. 12 numbers them.
struct D3Q19 {
  static constexpr int Q = 19;
  static constexpr std::array<int, Q> cx{0, 1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0};
  static constexpr std::array<int, Q> cy{0, 0, 0, 1, -1, 0, 0, 1, -1, -1, 1, 0, 0, 0, 0, 1, -1, 1, -1};
  static constexpr std::array<int, Q> cz{0, 0, 0, 0, 0, 1, -1, 0, 0, 0, 0, 1, -1, -1, 1, 1, -1, -1, 1};
  /// Eq. 12: E_0 = 1/3, E_1..6 = 1/18, E_7..18 = 1/36.
  static constexpr std::array<double, Q> w{
      1.0 / 3.0,  1.0 / 18.0, 1.0 / 18.0, 1.0 / 18.0, 1.0 / 18.0, 1.0 / 18.0, 1.0 / 18.0,
      1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0,
      1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0};
  /// Index of the direction with c_opp = -c.
  static constexpr std::array<int, Q> opp{0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13, 16, 15, 18, 17};
  /// Speed of sound squared in lattice units (c = dx/dt = 1).
  static constexpr double cs2 = 1.0 / 3.0;

  /// Index of the direction with the component along `axis` (0, 1, 2) reversed: specular
  /// reflection on a wall normal to that axis.
  static constexpr int mirror(int q, int axis) {
    const int mx = axis == 0 ? -cx[q] : cx[q];
    const int my = axis == 1 ? -cy[q] : cy[q];
    const int mz = axis == 2 ? -cz[q] : cz[q];
    for (int p = 0; p < Q; ++p)
      if (cx[p] == mx && cy[p] == my && cz[p] == mz) return p;
    return -1;
  }
  static constexpr int c(int q, int axis) { return axis == 0 ? cx[q] : axis == 1 ? cy[q] : cz[q]; }
};

}  // namespace cosim::fluid
