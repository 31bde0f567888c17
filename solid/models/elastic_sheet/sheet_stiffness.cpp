#include "solid/models/elastic_sheet/sheet_stiffness.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "protocol/units.hpp"

namespace cosim::solid {

namespace {

using protocol::PhysicalConstants;

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

/// Hartree energy, J (CODATA 2018): E_h = m_e (l_AU / t_AU)^2.
double hartree_J() {
  const double v = PhysicalConstants::bohr_m / PhysicalConstants::time_au_s;
  return PhysicalConstants::electron_mass_kg * v * v;
}

/// In-plane Q4 element of sides ha x hb, plane stress, 2 x 2 Gauss points; DOF 2 k + c
/// over the corners k = (0,0), (1,0), (0,1), (1,1) in (a, b) cell coordinates. Only the
/// aspect ratio matters (C is per unit length, the strain 1/h, the area ha hb).
Eigen::Matrix<double, 8, 8> q4_stiffness(const PlateConstantsAu& c, double ha, double hb) {
  Eigen::Matrix3d d;
  d << c.c11, c.c12, 0.0, c.c12, c.c22, 0.0, 0.0, 0.0, c.c66;
  const double g = 1.0 / std::sqrt(3.0);
  const std::array<std::array<int, 2>, 4> corner{{{0, 0}, {1, 0}, {0, 1}, {1, 1}}};
  Eigen::Matrix<double, 8, 8> k = Eigen::Matrix<double, 8, 8>::Zero();
  for (const double gx : {-g, g}) {
    for (const double gy : {-g, g}) {
      const double s = 0.5 * (1.0 + gx), t = 0.5 * (1.0 + gy);  // in [0, 1]
      Eigen::Matrix<double, 3, 8> b = Eigen::Matrix<double, 3, 8>::Zero();
      for (int q = 0; q < 4; ++q) {
        const auto& cq = corner[static_cast<std::size_t>(q)];
        // N = (cx ? s : 1 - s) (cy ? t : 1 - t); derivatives per unit length times h.
        const double dn_ds = (cq[0] ? 1.0 : -1.0) * (cq[1] ? t : 1.0 - t);
        const double dn_dt = (cq[1] ? 1.0 : -1.0) * (cq[0] ? s : 1.0 - s);
        b(0, 2 * q) = dn_ds / ha;
        b(1, 2 * q + 1) = dn_dt / hb;
        b(2, 2 * q) = dn_dt / hb;
        b(2, 2 * q + 1) = dn_ds / ha;
      }
      k += (0.25 * ha * hb) * b.transpose() * d * b;  // Gauss weight: a quarter of the cell
    }
  }
  return k;
}

}  // namespace

PlateConstantsAu plate_constants_au(const SheetConstants& si, double bending_poisson) {
  if (!(bending_poisson >= 0.0 && bending_poisson < 0.5))
    fail(__LINE__, "bending_poisson = " + std::to_string(bending_poisson) +
                       ": allowed [0, 0.5)");
  const double eh = hartree_J();
  const double per_area = PhysicalConstants::bohr_m * PhysicalConstants::bohr_m / eh;
  PlateConstantsAu c;
  c.c11 = si.c11_N_m * per_area;
  c.c22 = si.c22_N_m * per_area;
  c.c12 = si.c12_N_m * per_area;
  c.c66 = si.c66_N_m * per_area;
  c.d11 = si.d11_J / eh;
  c.d22 = si.d22_J / eh;
  c.d12 = bending_poisson * std::sqrt(c.d11 * c.d22);
  c.d66 = 0.5 * (si.d_mixed_J / eh - c.d12);
  if (!(c.c11 > 0.0 && c.c22 > 0.0 && c.c66 > 0.0 && c.c11 * c.c22 > c.c12 * c.c12 &&
        c.d11 > 0.0 && c.d22 > 0.0 && c.d66 > 0.0))
    fail(__LINE__, "the sheet's elastic constants are not positive definite (C11 " +
                       std::to_string(si.c11_N_m) + ", C12 " + std::to_string(si.c12_N_m) +
                       " N/m, D11 " + std::to_string(si.d11_J) + " J, D12 + 2 D66 " +
                       std::to_string(si.d_mixed_J) + " J)");
  return c;
}

std::vector<StiffnessTerm> sheet_stiffness_terms(const SheetSpec& spec, const PlateConstantsAu& c) {
  check_sheet_spec(spec);
  const double ha = spec.width_spacing_bohr, hb = spec.height_spacing_bohr;
  const int nx = spec.nx_cg, ny = spec.ny_cg;
  const int clamp = spec.clamped_rows - 1;  // the last clamped row: the plate's line
  std::vector<StiffnessTerm> terms;
  const auto neighbourhood = [&](int i, int j) {
    std::vector<Eigen::Index> f;
    for (int jj = std::max(0, j - 1); jj <= std::min(ny - 1, j + 1); ++jj)
      for (int ii = std::max(0, i - 1); ii <= std::min(nx - 1, i + 1); ++ii)
        f.push_back(spec.index(ii, jj));
    return f;
  };

  // Cells above the plate: Q4 in-plane element and the twist w_ab
  // (E = 2 D66 ha hb w_ab^2).
  const Eigen::Matrix<double, 8, 8> kq4 = q4_stiffness(c, ha, hb);
  for (int j = std::max(clamp, 0); j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      StiffnessTerm t;
      t.nodes = {spec.index(i, j), spec.index(i + 1, j), spec.index(i, j + 1),
                 spec.index(i + 1, j + 1)};
      t.frame = t.nodes;
      t.k = Eigen::MatrixXd::Zero(12, 12);
      for (int p = 0; p < 4; ++p)
        for (int q = 0; q < 4; ++q)
          t.k.block<2, 2>(3 * p, 3 * q) = kq4.block<2, 2>(2 * p, 2 * q);
      const Eigen::Vector4d s(1.0, -1.0, -1.0, 1.0);  // w_ab ha hb
      const Eigen::Matrix4d kw = (4.0 * c.d66 / (ha * hb)) * s * s.transpose();
      for (int p = 0; p < 4; ++p)
        for (int q = 0; q < 4; ++q) t.k(3 * p + 2, 3 * q + 2) += kw(p, q);
      terms.push_back(std::move(t));
    }
  }

  // Node terms: w_aa where both width neighbours exist, w_bb where both height neighbours
  // exist (or the clamped row's mirror ghost), coupled by D12 where both do.
  for (int j = std::max(clamp, 0); j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const bool clamped_row = j == clamp;
      const bool has_aa = !clamped_row && i >= 1 && i + 1 < nx;  // w = 0 along the clamp
      // A pinned row carries no bending moment along the height (a hinge): no w_bb there.
      const bool has_bb = (clamped_row ? !spec.pinned : j >= 1) && j + 1 < ny;
      if (!has_aa && !has_bb) continue;
      StiffnessTerm t;
      t.frame = neighbourhood(i, j);
      // Stencils over the term's nodes (h^2 times the second differences).
      std::vector<Eigen::Index> nodes{spec.index(i, j)};
      const auto slot = [&](int ii, int jj) {
        const Eigen::Index l = spec.index(ii, jj);
        for (std::size_t k = 0; k < nodes.size(); ++k)
          if (nodes[k] == l) return static_cast<Eigen::Index>(k);
        nodes.push_back(l);
        return static_cast<Eigen::Index>(nodes.size() - 1);
      };
      std::vector<std::pair<Eigen::Index, double>> saa, sbb;
      if (has_aa) saa = {{slot(i - 1, j), 1.0}, {0, -2.0}, {slot(i + 1, j), 1.0}};
      double area = ha * hb;
      if (has_bb) {
        if (clamped_row) {
          // Mirror ghost below the plate's line: w_{j-1} = w_{j+1}, half the area.
          sbb = {{0, -2.0}, {slot(i, j + 1), 2.0}};
          area = 0.5 * ha * hb;
          t.frame.clear();  // the plate's frame
        } else {
          sbb = {{slot(i, j - 1), 1.0}, {0, -2.0}, {slot(i, j + 1), 1.0}};
        }
      }
      const Eigen::Index m = static_cast<Eigen::Index>(nodes.size());
      Eigen::MatrixXd s = Eigen::MatrixXd::Zero(2, m);  // rows: w_aa, w_bb per unit w
      for (const auto& [k, v] : saa) s(0, k) += v / (ha * ha);
      for (const auto& [k, v] : sbb) s(1, k) += v / (hb * hb);
      Eigen::Matrix2d d;
      d << (has_aa ? c.d11 : 0.0), (has_aa && has_bb ? c.d12 : 0.0),
          (has_aa && has_bb ? c.d12 : 0.0), (has_bb ? c.d22 : 0.0);
      // E = 1/2 area (w'')^T D (w''), w'' = s w.
      const Eigen::MatrixXd kw = area * s.transpose() * d * s;
      t.nodes = nodes;
      t.k = Eigen::MatrixXd::Zero(3 * m, 3 * m);
      for (Eigen::Index p = 0; p < m; ++p)
        for (Eigen::Index q = 0; q < m; ++q) t.k(3 * p + 2, 3 * q + 2) = kw(p, q);
      terms.push_back(std::move(t));
    }
  }
  return terms;
}

Eigen::SparseMatrix<double> assemble_stiffness(const std::vector<StiffnessTerm>& terms,
                                               Eigen::Index num_cgps) {
  std::vector<Eigen::Triplet<double>> entries;
  for (const StiffnessTerm& t : terms) {
    const auto m = static_cast<Eigen::Index>(t.nodes.size());
    for (Eigen::Index p = 0; p < m; ++p)
      for (Eigen::Index q = 0; q < m; ++q)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const double v = t.k(3 * p + a, 3 * q + b);
            if (v != 0.0)
              entries.emplace_back(3 * t.nodes[static_cast<std::size_t>(p)] + a,
                                   3 * t.nodes[static_cast<std::size_t>(q)] + b, v);
          }
  }
  Eigen::SparseMatrix<double> k(3 * num_cgps, 3 * num_cgps);
  k.setFromTriplets(entries.begin(), entries.end());  // sums duplicates
  return k;
}

Eigen::Matrix3d sheet_axes(const SheetSpec& spec) {
  Eigen::Matrix3d q;
  q.col(0) = sheet_width_direction(spec);
  q.col(1) = sheet_height_direction(spec);
  q.col(2) = sheet_normal(spec);
  return q;
}

}  // namespace cosim::solid
