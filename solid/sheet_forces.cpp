#include "solid/sheet_forces.hpp"

#include <Eigen/Dense>
#include <Eigen/SVD>

namespace cosim::solid {

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
      for (std::size_t k = 0; k < t.frame.size(); ++k) {
        c.frame.push_back(s.first + t.frame[k]);
        c.ref_frame.col(static_cast<Eigen::Index>(k)) = s.reference_bohr.col(t.frame[k]) - centre;
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
      Eigen::VectorXd u(3 * m);
      for (Eigen::Index p = 0; p < m; ++p)
        u.segment<3>(3 * p) = x.col(t.nodes[static_cast<std::size_t>(p)]) - t.ref_nodes.col(p);
      const Eigen::VectorXd g = t.k * u;
      energy += 0.5 * u.dot(g);
      for (Eigen::Index p = 0; p < m; ++p) f.col(t.nodes[static_cast<std::size_t>(p)]) -= g.segment<3>(3 * p);
      continue;
    }
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const Eigen::Index l : t.frame) centre += x.col(l);
    centre /= static_cast<double>(nf);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (Eigen::Index k = 0; k < nf; ++k)
      cov += (x.col(t.frame[static_cast<std::size_t>(k)]) - centre) * t.ref_frame.col(k).transpose();
    // Polar decomposition by SVD; the frame is flat at rest (rank 2), so the sign of the
    // third singular pair is chosen to make R a proper rotation.
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
    d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
    const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
    const Eigen::Matrix3d s = r.transpose() * cov;

    Eigen::VectorXd u(3 * m);
    Eigen::Matrix3Xd y(3, m);
    for (Eigen::Index p = 0; p < m; ++p) {
      y.col(p) = r.transpose() * (x.col(t.nodes[static_cast<std::size_t>(p)]) - centre);
      u.segment<3>(3 * p) = y.col(p) - t.ref_nodes.col(p);
    }
    const Eigen::VectorXd g = t.k * u;
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
