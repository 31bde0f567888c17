// The corotational sheet force as it was evaluated one term at a time, before the terms
// were batched by shape and stiffness (solid/models/elastic_sheet/sheet_forces.cpp): kept as the reference the
// batched CorotationalSheetForce must match to round-off. Same physics (the U K U term of
// Eq. 4 per term in its own rotated frame, F^int = -dE/dx of Eq. 20); see sheet_forces.hpp.
#pragma once

#include <cmath>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "solid/models/elastic_sheet/sheet_forces.hpp"

namespace cosim::solid::reference {

class CorotationalPerTerm {
 public:
  explicit CorotationalPerTerm(const std::vector<SheetBlock>& sheets) {
    for (const SheetBlock& s : sheets) {
      for (const StiffnessTerm& t : s.terms) {
        Term c;
        const auto m = static_cast<Eigen::Index>(t.nodes.size());
        if (m > kMaxTermNodes) throw std::logic_error("reference: a term of too many CGPs");
        const bool no_normal = component_unused(t.k, 2);
        const bool no_plane = component_unused(t.k, 0) && component_unused(t.k, 1);
        if (no_normal && !no_plane) {
          c.coupling = 0;
          c.k.resize(2 * m, 2 * m);
          for (Eigen::Index p = 0; p < m; ++p)
            for (Eigen::Index q = 0; q < m; ++q)
              c.k.block<2, 2>(2 * p, 2 * q) = t.k.block<2, 2>(3 * p, 3 * q);
        } else if (no_plane && !no_normal) {
          c.coupling = 1;
          c.k.resize(m, m);
          for (Eigen::Index p = 0; p < m; ++p)
            for (Eigen::Index q = 0; q < m; ++q) c.k(p, q) = t.k(3 * p + 2, 3 * q + 2);
        } else {
          c.coupling = 2;
          c.k = t.k;
        }
        c.axes = s.axes;
        Eigen::Vector3d centre = Eigen::Vector3d::Zero();
        for (const Eigen::Index l : t.frame) centre += s.reference_bohr.col(l);
        if (!t.frame.empty()) centre /= static_cast<double>(t.frame.size());
        c.ref_nodes.resize(3, m);
        for (Eigen::Index p = 0; p < m; ++p) {
          const Eigen::Index l = t.nodes[static_cast<std::size_t>(p)];
          c.nodes.push_back(s.first + l);
          c.ref_nodes.col(p) = s.axes.transpose() * (s.reference_bohr.col(l) - centre);
        }
        c.ref_frame.resize(3, static_cast<Eigen::Index>(t.frame.size()));
        c.ref_frame_ab.resize(2, static_cast<Eigen::Index>(t.frame.size()));
        for (std::size_t k = 0; k < t.frame.size(); ++k) {
          const auto kk = static_cast<Eigen::Index>(k);
          c.frame.push_back(s.first + t.frame[k]);
          c.ref_frame.col(kk) = s.axes.transpose() * (s.reference_bohr.col(t.frame[k]) - centre);
          c.ref_frame_ab.col(kk) = c.ref_frame.col(kk).head<2>();
        }
        terms_.push_back(std::move(c));
      }
    }
  }

  double evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const {
    f.setZero();
    double energy = 0.0;
    for (const Term& t : terms_) {
      const auto nf = static_cast<Eigen::Index>(t.frame.size());
      const auto m = static_cast<Eigen::Index>(t.nodes.size());
      TermPoints u(3, m), g(3, m);
      if (nf == 0) {
        for (Eigen::Index p = 0; p < m; ++p)
          u.col(p) = t.axes.transpose() * x.col(t.nodes[static_cast<std::size_t>(p)]) - t.ref_nodes.col(p);
        apply_term(t.k, t.coupling, u, g, energy);
        for (Eigen::Index p = 0; p < m; ++p) f.col(t.nodes[static_cast<std::size_t>(p)]) -= t.axes * g.col(p);
        continue;
      }
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const Eigen::Index l : t.frame) centre += x.col(l);
      centre /= static_cast<double>(nf);
      Eigen::Matrix<double, 3, 2> a2 = Eigen::Matrix<double, 3, 2>::Zero();
      for (Eigen::Index k = 0; k < nf; ++k)
        a2 += (x.col(t.frame[static_cast<std::size_t>(k)]) - centre) * t.ref_frame_ab.col(k).transpose();
      const Eigen::Matrix2d m2 = a2.transpose() * a2;
      const double det_root = std::sqrt(m2.determinant());
      const Eigen::Matrix2d root =
          (m2 + det_root * Eigen::Matrix2d::Identity()) / std::sqrt(m2.trace() + 2.0 * det_root);
      const double tr_root = root.trace(), det_root_m = root.determinant();
      const Eigen::Matrix2d adj_root = tr_root * Eigen::Matrix2d::Identity() - root;
      const Eigen::Matrix<double, 3, 2> q = a2 * (adj_root / det_root_m);
      Eigen::Matrix3d ra;
      ra.leftCols<2>() = q;
      ra.col(2) = q.col(0).cross(q.col(1));
      TermPoints y(3, m);
      for (Eigen::Index p = 0; p < m; ++p) {
        y.col(p) = ra.transpose() * (x.col(t.nodes[static_cast<std::size_t>(p)]) - centre);
        u.col(p) = y.col(p) - t.ref_nodes.col(p);
      }
      apply_term(t.k, t.coupling, u, g, energy);
      Eigen::Vector3d tau = Eigen::Vector3d::Zero();
      Eigen::Vector3d g_sum = Eigen::Vector3d::Zero();
      for (Eigen::Index p = 0; p < m; ++p) {
        tau += y.col(p).cross(g.col(p));
        g_sum += g.col(p);
        f.col(t.nodes[static_cast<std::size_t>(p)]) -= ra * g.col(p);
      }
      Eigen::Vector3d mu;
      mu.head<2>() = root * tau.head<2>() / det_root_m;
      mu(2) = tau(2) / tr_root;
      const Eigen::Vector3d shift = ra * g_sum / static_cast<double>(nf);
      for (Eigen::Index k = 0; k < nf; ++k) {
        const Eigen::Index l = t.frame[static_cast<std::size_t>(k)];
        f.col(l) += ra * mu.cross(t.ref_frame.col(k)) + shift;
      }
    }
    return energy;
  }

 private:
  static constexpr int kMaxTermNodes = 9;
  using TermVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3 * kMaxTermNodes, 1>;
  using TermPoints = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxTermNodes>;
  struct Term {
    std::vector<Eigen::Index> nodes, frame;
    int coupling = 2;  // 0 in-plane, 1 normal, 2 all
    Eigen::MatrixXd k;
    Eigen::Matrix3Xd ref_nodes;
    Eigen::Matrix2Xd ref_frame_ab;
    Eigen::Matrix3Xd ref_frame;
    Eigen::Matrix3d axes;
  };

  static bool component_unused(const Eigen::MatrixXd& k, int c) {
    for (Eigen::Index i = c; i < k.rows(); i += 3)
      if (!k.row(i).isZero(0.0) || !k.col(i).isZero(0.0)) return false;
    return true;
  }

  static void apply_term(const Eigen::MatrixXd& k, int coupling, const TermPoints& u,
                         TermPoints& g, double& energy) {
    const auto m = u.cols();
    if (coupling == 0) {
      TermVector v(2 * m);
      for (Eigen::Index p = 0; p < m; ++p) v.segment<2>(2 * p) = u.col(p).head<2>();
      const TermVector kv = k * v;
      energy += 0.5 * v.dot(kv);
      for (Eigen::Index p = 0; p < m; ++p) g.col(p) << kv(2 * p), kv(2 * p + 1), 0.0;
    } else if (coupling == 1) {
      TermVector v(m);
      for (Eigen::Index p = 0; p < m; ++p) v(p) = u(2, p);
      const TermVector kv = k * v;
      energy += 0.5 * v.dot(kv);
      for (Eigen::Index p = 0; p < m; ++p) g.col(p) << 0.0, 0.0, kv(p);
    } else {
      const TermVector v = Eigen::Map<const TermVector>(u.data(), 3 * m);
      const TermVector kv = k * v;
      energy += 0.5 * v.dot(kv);
      g = Eigen::Map<const TermPoints>(kv.data(), 3, m);
    }
  }

  std::vector<Term> terms_;
};

}  // namespace cosim::solid::reference
