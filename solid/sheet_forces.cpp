#include "solid/sheet_forces.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace cosim::solid {

namespace {

/// Scratch of a term's local vectors, on the stack: a term touches at most 9 CGPs.
constexpr int kMaxTermNodes = 9;
using TermVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3 * kMaxTermNodes, 1>;
using TermPoints = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxTermNodes>;

}  // namespace

double LinearSheetForce::evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const {
  double energy = 0.0;
  for (const SheetBlock& s : sheets_) {
    Eigen::Matrix3Xd u = s.axes.transpose() * (x.middleCols(s.first, s.count) - s.reference_bohr);
    // K annihilates a rigid translation exactly, but K t in floating point is round-off of
    // the size of t: take the mean displacement out so that a sheet carried far by the flow
    // does not leak momentum (its internal forces must sum to zero).
    u.colwise() -= u.rowwise().mean();
    const Eigen::Map<const Eigen::VectorXd> u_flat(u.data(), 3 * s.count);
    const Eigen::VectorXd ku = s.stiffness * u_flat;
    energy += 0.5 * u_flat.dot(ku);
    f.middleCols(s.first, s.count) = -s.axes * Eigen::Map<const Eigen::Matrix3Xd>(ku.data(), 3, s.count);
  }
  return energy;
}

CorotationalSheetForce::CorotationalSheetForce(const std::vector<SheetBlock>& sheets) {
  for (const SheetBlock& s : sheets) {
    for (const StiffnessTerm& t : s.terms) {
      Term c;
      const auto m = static_cast<Eigen::Index>(t.nodes.size());
      if (m > kMaxTermNodes)
        throw std::logic_error("CorotationalSheetForce: a term of " + std::to_string(m) +
                               " CGPs; the scratch holds " + std::to_string(kMaxTermNodes));
      // K in scene axes: blockwise A K A^T.
      c.k = Eigen::MatrixXd(3 * m, 3 * m);
      for (Eigen::Index p = 0; p < m; ++p)
        for (Eigen::Index q = 0; q < m; ++q)
          c.k.block<3, 3>(3 * p, 3 * q) = s.axes * t.k.block<3, 3>(3 * p, 3 * q) * s.axes.transpose();
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const Eigen::Index l : t.frame) centre += s.reference_bohr.col(l);
      if (!t.frame.empty()) centre /= static_cast<double>(t.frame.size());
      c.ref_nodes.resize(3, m);
      for (Eigen::Index p = 0; p < m; ++p) {
        const Eigen::Index l = t.nodes[static_cast<std::size_t>(p)];
        c.nodes.push_back(s.first + l);
        c.ref_nodes.col(p) = s.reference_bohr.col(l) - centre;
      }
      c.ref_frame.resize(3, static_cast<Eigen::Index>(t.frame.size()));
      c.ref_frame_ab.resize(2, static_cast<Eigen::Index>(t.frame.size()));
      c.plane = s.axes.leftCols<2>();
      c.normal = s.axes.col(2);
      for (std::size_t k = 0; k < t.frame.size(); ++k) {
        const auto kk = static_cast<Eigen::Index>(k);
        c.frame.push_back(s.first + t.frame[k]);
        c.ref_frame.col(kk) = s.reference_bohr.col(t.frame[k]) - centre;
        c.ref_frame_ab.col(kk) = c.plane.transpose() * c.ref_frame.col(kk);
      }
      terms_.push_back(std::move(c));
    }
  }
}

double CorotationalSheetForce::evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const {
  f.setZero();
  double energy = 0.0;
  for (const Term& t : terms_) {
    const auto nf = static_cast<Eigen::Index>(t.frame.size());
    const auto m = static_cast<Eigen::Index>(t.nodes.size());
    if (nf == 0) {  // a term tied to the plate: evaluated in the fixed frame
      TermVector u(3 * m);
      for (Eigen::Index p = 0; p < m; ++p)
        u.segment<3>(3 * p) = x.col(t.nodes[static_cast<std::size_t>(p)]) - t.ref_nodes.col(p);
      const TermVector g = t.k * u;
      energy += 0.5 * u.dot(g);
      for (Eigen::Index p = 0; p < m; ++p) f.col(t.nodes[static_cast<std::size_t>(p)]) -= g.segment<3>(3 * p);
      continue;
    }
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const Eigen::Index l : t.frame) centre += x.col(l);
    centre /= static_cast<double>(nf);
    // Polar decomposition of the flat frame's F = A P^T (see the header).
    Eigen::Matrix<double, 3, 2> a2 = Eigen::Matrix<double, 3, 2>::Zero();
    for (Eigen::Index k = 0; k < nf; ++k)
      a2 += (x.col(t.frame[static_cast<std::size_t>(k)]) - centre) * t.ref_frame_ab.col(k).transpose();
    const Eigen::Matrix2d m2 = a2.transpose() * a2;
    const double det_root = std::sqrt(m2.determinant());
    const Eigen::Matrix2d root =  // (A^T A)^(1/2) of a 2 x 2 SPD matrix, closed form
        (m2 + det_root * Eigen::Matrix2d::Identity()) / std::sqrt(m2.trace() + 2.0 * det_root);
    const Eigen::Matrix<double, 3, 2> q = a2 * root.inverse();
    const Eigen::Vector3d qn = q.col(0).cross(q.col(1));
    const Eigen::Matrix3d r = q * t.plane.transpose() + qn * t.normal.transpose();
    const Eigen::Matrix3d s = t.plane * root * t.plane.transpose();

    TermVector u(3 * m);
    TermPoints y(3, m);
    for (Eigen::Index p = 0; p < m; ++p) {
      y.col(p) = r.transpose() * (x.col(t.nodes[static_cast<std::size_t>(p)]) - centre);
      u.segment<3>(3 * p) = y.col(p) - t.ref_nodes.col(p);
    }
    const TermVector g = t.k * u;
    energy += 0.5 * u.dot(g);

    // dE = sum_k g_k . R^T (dx_k - dc) - omega . tau,  tau = sum_k y_k x g_k.
    Eigen::Vector3d tau = Eigen::Vector3d::Zero();
    Eigen::Vector3d g_sum = Eigen::Vector3d::Zero();
    for (Eigen::Index p = 0; p < m; ++p) {
      const Eigen::Vector3d gp = g.segment<3>(3 * p);
      tau += y.col(p).cross(gp);
      g_sum += gp;
      f.col(t.nodes[static_cast<std::size_t>(p)]) -= r * gp;
    }
    const Eigen::Matrix3d a = s.trace() * Eigen::Matrix3d::Identity() - s;
    const Eigen::Vector3d mu = a.partialPivLu().solve(tau);
    const Eigen::Vector3d shift = r * g_sum / static_cast<double>(nf);
    for (Eigen::Index k = 0; k < nf; ++k) {
      const Eigen::Index l = t.frame[static_cast<std::size_t>(k)];
      // -dE/dx_f = R (mu x b_f) + R sum_k g_k / n_f
      f.col(l) += r * mu.cross(t.ref_frame.col(k)) + shift;
    }
  }
  return energy;
}

}  // namespace cosim::solid
