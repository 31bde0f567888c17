#include "solid/models/elastic_sheet/sheet_forces.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace cosim::solid {

namespace {

/// A term touches at most 9 CGPs, and its frame at most 9.
constexpr int kMaxTermNodes = 9;

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

namespace {

/// Largest point count of a term: its frame and its nodes outside the frame.
constexpr int kMaxTermPoints = 2 * kMaxTermNodes;
constexpr int L = CorotationalSheetForce::kLanes;

/// Whether every entry of k in the rows and columns of local component `c` (DOF 3 p + c)
/// is zero.
bool component_unused(const Eigen::MatrixXd& k, int c) {
  for (Eigen::Index i = c; i < k.rows(); i += 3)
    if (!k.row(i).isZero(0.0) || !k.col(i).isZero(0.0)) return false;
  return true;
}

/// Whether k couples the in-plane components (a, b) with the normal one n.
bool plane_normal_coupled(const Eigen::MatrixXd& k) {
  for (Eigen::Index i = 0; i < k.rows(); ++i)
    for (Eigen::Index j = 0; j < k.cols(); ++j)
      if ((i % 3 == 2) != (j % 3 == 2) && k(i, j) != 0.0) return true;
  return false;
}

/// The rows and columns of k (3m x 3m, DOF 3 p + c) of the components `comps`, row-major.
std::vector<double> pick(const Eigen::MatrixXd& k, const std::vector<int>& comps) {
  const auto m = k.rows() / 3;
  std::vector<double> out;
  for (Eigen::Index p = 0; p < m; ++p)
    for (const int a : comps)
      for (Eigen::Index q = 0; q < m; ++q)
        for (const int b : comps) out.push_back(k(3 * p + a, 3 * q + b));
  return out;
}

using Lanes = CorotationalSheetForce::Lanes;

#if defined(__AVX512F__)
static_assert(L % 8 == 0, "whole AVX-512 registers of lanes");
#endif

/// a b + c and c - a b for every lane, fused where the machine has AVX-512 (they differ
/// from the separate product and sum by round-off only).
inline Lanes madd(const Lanes& a, const Lanes& b, const Lanes& c) {
#if defined(__AVX512F__)
  Lanes r;
  for (int o = 0; o < L; o += 8)
    _mm512_store_pd(r.data() + o, _mm512_fmadd_pd(_mm512_load_pd(a.data() + o), _mm512_load_pd(b.data() + o),
                                                  _mm512_load_pd(c.data() + o)));
  return r;
#else
  return a * b + c;
#endif
}
inline Lanes madd(double a, const Lanes& b, const Lanes& c) {
#if defined(__AVX512F__)
  Lanes r;
  for (int o = 0; o < L; o += 8)
    _mm512_store_pd(r.data() + o, _mm512_fmadd_pd(_mm512_set1_pd(a), _mm512_load_pd(b.data() + o),
                                                  _mm512_load_pd(c.data() + o)));
  return r;
#else
  return a * b + c;
#endif
}
inline Lanes nmadd(const Lanes& a, const Lanes& b, const Lanes& c) {
#if defined(__AVX512F__)
  Lanes r;
  for (int o = 0; o < L; o += 8)
    _mm512_store_pd(r.data() + o, _mm512_fnmadd_pd(_mm512_load_pd(a.data() + o), _mm512_load_pd(b.data() + o),
                                                   _mm512_load_pd(c.data() + o)));
  return r;
#else
  return c - a * b;
#endif
}

/// kv = K v for the n-vector v of every lane (K n x n, row-major, the group's), and the
/// lanes' energies e += 1/2 v . kv (E_t = 1/2 u^T K u, the U K U term of Eq. 4). kN: n
/// when known at compile time (the loops unrolled), else -1 (K's zeros skipped).
template <int kN>
inline void apply_k(const double* k, int n, const Lanes* v, Lanes* kv, Lanes& e) {
  if constexpr (kN >= 0) n = kN;
  for (int i = 0; i < n; ++i) {
    Lanes acc = Lanes::Zero();
    for (int j = 0; j < n; ++j)
      if (kN >= 0 || k[i * n + j] != 0.0) acc = madd(k[i * n + j], v[j], acc);
    kv[i] = acc;
    e += 0.5 * v[i] * acc;
  }
}

constexpr int kInPlane = static_cast<int>(CorotationalSheetForce::Coupling::InPlane);
constexpr int kNormal = static_cast<int>(CorotationalSheetForce::Coupling::Normal);
constexpr int kSplit = static_cast<int>(CorotationalSheetForce::Coupling::Split);
constexpr int kAll = static_cast<int>(CorotationalSheetForce::Coupling::All);

}  // namespace

CorotationalSheetForce::CorotationalSheetForce(const std::vector<SheetBlock>& sheets,
                                               Kernels kernels) {
  // One term, before it is batched: its points (model-wide), reference geometry and the
  // group it belongs to.
  struct Pending {
    std::vector<int> points;
    Eigen::Matrix3Xd ref_frame, ref_nodes;
  };
  std::vector<std::vector<Pending>> pending;
  for (const SheetBlock& s : sheets) {
    for (const StiffnessTerm& t : s.terms) {
      const auto m = static_cast<Eigen::Index>(t.nodes.size());
      const auto nf = static_cast<Eigen::Index>(t.frame.size());
      if (m > kMaxTermNodes || nf > kMaxTermNodes)
        throw std::logic_error("CorotationalSheetForce: a term of " + std::to_string(m) +
                               " CGPs and a frame of " + std::to_string(nf) + "; at most " +
                               std::to_string(kMaxTermNodes) + " each");
      Group g;
      g.nf = static_cast<int>(nf);
      g.m = static_cast<int>(m);
      // K stays in the sheet's local axes; keep only the components it couples.
      const bool no_normal = component_unused(t.k, 2);
      const bool no_plane = component_unused(t.k, 0) && component_unused(t.k, 1);
      if (no_normal && !no_plane) {
        g.coupling = Coupling::InPlane;
        g.k_plane = pick(t.k, {0, 1});
      } else if (no_plane && !no_normal) {
        g.coupling = Coupling::Normal;
        g.k_normal = pick(t.k, {2});
      } else if (!plane_normal_coupled(t.k)) {
        g.coupling = Coupling::Split;
        g.k_plane = pick(t.k, {0, 1});
        g.k_normal = pick(t.k, {2});
      } else {
        g.coupling = Coupling::All;
        g.k_all = pick(t.k, {0, 1, 2});
      }
      g.axes = nf == 0 ? s.axes : Eigen::Matrix3d::Zero();
      // Points: the frame, then the nodes outside it.
      Pending pt;
      for (const Eigen::Index l : t.frame) pt.points.push_back(static_cast<int>(s.first + l));
      for (const Eigen::Index l : t.nodes) {
        const int global = static_cast<int>(s.first + l);
        const auto it = std::find(pt.points.begin(), pt.points.end(), global);
        g.slot.push_back(static_cast<int>(it - pt.points.begin()));
        if (it == pt.points.end()) pt.points.push_back(global);
      }
      g.np = static_cast<int>(pt.points.size());
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const Eigen::Index l : t.frame) centre += s.reference_bohr.col(l);
      if (nf > 0) centre /= static_cast<double>(nf);
      pt.ref_nodes.resize(3, m);
      for (Eigen::Index p = 0; p < m; ++p)
        pt.ref_nodes.col(p) = s.axes.transpose() *
                              (s.reference_bohr.col(t.nodes[static_cast<std::size_t>(p)]) - centre);
      pt.ref_frame.resize(3, nf);
      for (Eigen::Index k = 0; k < nf; ++k)
        pt.ref_frame.col(k) = s.axes.transpose() *
                              (s.reference_bohr.col(t.frame[static_cast<std::size_t>(k)]) - centre);

      // The group of equal shape, coupling and (bit-equal) K.
      std::size_t gi = 0;
      for (; gi < groups_.size(); ++gi) {
        const Group& o = groups_[gi];
        if (o.nf == g.nf && o.m == g.m && o.np == g.np && o.coupling == g.coupling &&
            o.slot == g.slot && o.k_plane == g.k_plane && o.k_normal == g.k_normal &&
            o.k_all == g.k_all && o.axes == g.axes)
          break;
      }
      if (gi == groups_.size()) {
        groups_.push_back(std::move(g));
        pending.emplace_back();
      }
      pending[gi].push_back(std::move(pt));
    }
  }
  // Structure of arrays by batch; the last batch's empty lanes repeat its first term (they
  // are computed, but neither their forces nor their energies are added).
  std::size_t out_size = 0;
  Eigen::Index num_cgps = 0;
  for (const SheetBlock& s : sheets) num_cgps = std::max(num_cgps, s.first + s.count);
  std::vector<std::vector<std::size_t>> contributions(static_cast<std::size_t>(num_cgps));
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    Group& g = groups_[gi];
    const std::vector<Pending>& terms = pending[gi];
    g.count = static_cast<int>(terms.size());
    g.batches = (g.count + L - 1) / L;
    const auto nb = static_cast<std::size_t>(g.batches);
    g.first_out = out_size;
    out_size += nb * static_cast<std::size_t>(g.np * 3);
    g.offsets.resize(nb * static_cast<std::size_t>(g.np * L));
    g.ref_frame.resize(nb * static_cast<std::size_t>(g.nf * 3));
    g.ref_nodes.resize(nb * static_cast<std::size_t>(g.m * 3));
    for (int b = 0; b < g.batches; ++b) {
      for (int l = 0; l < L; ++l) {
        const int ti = b * L + l < g.count ? b * L + l : b * L;
        const Pending& t = terms[static_cast<std::size_t>(ti)];
        for (int s = 0; s < g.np; ++s) {
          const int cgp = t.points[static_cast<std::size_t>(s)];
          g.offsets[static_cast<std::size_t>((b * g.np + s) * L + l)] = 3 * cgp;
          if (b * L + l < g.count)
            contributions[static_cast<std::size_t>(cgp)].push_back(
                (g.first_out + static_cast<std::size_t>((b * g.np + s) * 3)) * L +
                static_cast<std::size_t>(l));
        }
        for (int s = 0; s < g.nf; ++s)
          for (int c = 0; c < 3; ++c)
            g.ref_frame[static_cast<std::size_t>((b * g.nf + s) * 3 + c)][l] = t.ref_frame(c, s);
        for (int p = 0; p < g.m; ++p)
          for (int c = 0; c < 3; ++c)
            g.ref_nodes[static_cast<std::size_t>((b * g.m + p) * 3 + c)][l] = t.ref_nodes(c, p);
      }
    }
  }
  for (Group& g : groups_) {
    const auto is = [&g, kernels](int nf, int np, int m, Coupling c) {
      return kernels == Kernels::Compiled && g.nf == nf && g.np == np && g.m == m &&
             g.coupling == c;
    };
    // The terms of a rectangular sheet (sheet_stiffness.cpp): cells (Q4 and twist), the
    // bulk's, an edge's and the free end's plate stencils, and the clamped row's.
    if (is(4, 4, 4, Coupling::Split))
      g.kernel = &CorotationalSheetForce::evaluate_batches<4, 4, 4, kSplit>;
    else if (is(9, 9, 5, Coupling::Normal))
      g.kernel = &CorotationalSheetForce::evaluate_batches<9, 9, 5, kNormal>;
    else if (is(6, 6, 3, Coupling::Normal))
      g.kernel = &CorotationalSheetForce::evaluate_batches<6, 6, 3, kNormal>;
    else if (is(0, 2, 2, Coupling::Normal))
      g.kernel = &CorotationalSheetForce::evaluate_batches<0, 2, 2, kNormal>;
    else
      g.kernel = &CorotationalSheetForce::evaluate_batches<-1, -1, -1, -1>;
  }
  // Every CGP's list padded to the longest with a record of zeros past the batches' (a
  // fixed trip count: the loop's exit is not mispredicted at every CGP).
  out_.assign(out_size + 3, Lanes::Zero());
  std::size_t longest = 0;
  for (const std::vector<std::size_t>& c : contributions) longest = std::max(longest, c.size());
  gather_per_cgp_ = longest;
  for (const std::vector<std::size_t>& c : contributions) {
    gather_.insert(gather_.end(), c.begin(), c.end());
    gather_.insert(gather_.end(), longest - c.size(), out_size * L);
  }
}

double CorotationalSheetForce::evaluate(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) const {
  double energy = 0.0;
  for (const Group& g : groups_) (this->*g.kernel)(g, x.data(), energy);
  // Each CGP's force: the sum of what the terms of its frames and nodes give it.
  f.setZero();
  const double* out = out_.front().data();
  const std::size_t* entry = gather_.data();
  const auto cgps = gather_per_cgp_ > 0 ? static_cast<Eigen::Index>(gather_.size() / gather_per_cgp_) : 0;
  for (Eigen::Index l = 0; l < cgps; ++l) {
    double fa = 0.0, fb = 0.0, fn = 0.0;
    for (std::size_t k = 0; k < gather_per_cgp_; ++k) {
      const double* o = out + *entry++;
      fa += o[0];
      fb += o[L];
      fn += o[2 * L];
    }
    f(0, l) = fa;
    f(1, l) = fb;
    f(2, l) = fn;
  }
  return energy;
}

// One group, a batch of L terms at a time, each lane one term: gather the points' x, the
// lanes' frames and rotations, u, K u and the gradient, then add the forces -dE/dx
// (F^int of Eq. 20) into f one lane after the other (terms of a batch share CGPs).
template <int kNf, int kNp, int kM, int kCoupling>
void CorotationalSheetForce::evaluate_batches(const Group& g, const double* x,
                                              double& energy) const {
  using V = Lanes;
  const int nf = kNf >= 0 ? kNf : g.nf, m = kM >= 0 ? kM : g.m, np = kNp >= 0 ? kNp : g.np;
  const int coupling = kCoupling >= 0 ? kCoupling : static_cast<int>(g.coupling);
  constexpr int kPlaneN = kM >= 0 ? 2 * kM : -1, kAllN = kM >= 0 ? 3 * kM : -1;
  V d[kMaxTermPoints][3];  // x - c of every point, scene axes
  V y[kMaxTermNodes][3];   // R^T (x_k - c) of the nodes, local axes
  V u[3 * kMaxTermNodes], kv[3 * kMaxTermNodes];
  V gl[kMaxTermNodes][3];  // K u of the nodes, local axes
  V h[kMaxTermPoints][3];  // -dE/dx of every point, local axes
  V ra[3][3];              // R A: the sheet's axes rotated with the frame
  V r00, r01, r11, inv_tr_root, inv_det_root;
  const double inv_nf = nf > 0 ? 1.0 / nf : 0.0;
  V e_sum = V::Zero();  // the group's energy per lane
  if (nf == 0)  // a term tied to the plate: evaluated in the fixed frame (c = 0)
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) ra[c][i] = V::Constant(g.axes(c, i));
  for (int b = 0; b < g.batches; ++b) {
    const int* off = g.offsets.data() + static_cast<std::ptrdiff_t>(b) * np * L;
    const V* rf = g.ref_frame.data() + static_cast<std::ptrdiff_t>(b) * nf * 3;
    const V* rn = g.ref_nodes.data() + static_cast<std::ptrdiff_t>(b) * m * 3;
    const int valid = std::min(L, g.count - b * L);
    for (int s = 0; s < np; ++s) {
#if defined(__AVX512F__)
      for (int o = 0; o < L; o += 8) {
        const __m256i idx = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(off + s * L + o));
        for (int c = 0; c < 3; ++c)
          _mm512_store_pd(d[s][c].data() + o, _mm512_i32gather_pd(idx, x + c, 8));
      }
#else
      for (int c = 0; c < 3; ++c)
        for (int l = 0; l < L; ++l) d[s][c][l] = x[off[s * L + l] + c];
#endif
    }
    if (nf > 0) {
      for (int c = 0; c < 3; ++c) {
        V cen = d[0][c];
        for (int s = 1; s < nf; ++s) cen += d[s][c];
        cen *= inv_nf;
        for (int s = 0; s < np; ++s) d[s][c] -= cen;
      }
      // Polar decomposition of the flat frame's F = A P^T (see the header), with P = the
      // sheet's (e_a, e_b): Q = A (A^T A)^(-1/2) are the rotated e_a, e_b.
      V a2[3][2];
      for (int c = 0; c < 3; ++c)
        for (int j = 0; j < 2; ++j) {
          a2[c][j] = d[0][c] * rf[j];
          for (int s = 1; s < nf; ++s) a2[c][j] = madd(d[s][c], rf[s * 3 + j], a2[c][j]);
        }
      const V m00 = a2[0][0] * a2[0][0] + a2[1][0] * a2[1][0] + a2[2][0] * a2[2][0];
      const V m01 = a2[0][0] * a2[0][1] + a2[1][0] * a2[1][1] + a2[2][0] * a2[2][1];
      const V m11 = a2[0][1] * a2[0][1] + a2[1][1] * a2[1][1] + a2[2][1] * a2[2][1];
      const V dr = (m00 * m11 - m01 * m01).sqrt();
      // (A^T A)^(1/2) of a 2 x 2 SPD matrix, closed form: (M + sqrt(det M) I) / sqrt(...)
      // (One division per lane for each of 1/sqrt(...), 1/det(root) and 1/tr(root).)
      const V inv_sr = (m00 + m11 + 2.0 * dr).sqrt().inverse();
      r00 = (m00 + dr) * inv_sr;
      r01 = m01 * inv_sr;
      r11 = (m11 + dr) * inv_sr;
      const V tr_root = r00 + r11;
      inv_tr_root = tr_root.inverse();
      inv_det_root = (r00 * r11 - r01 * r01).inverse();
      // root^-1 = adj(root) / det(root), adj(M) = tr(M) I - M for a 2 x 2 M.
      const V i00 = (tr_root - r00) * inv_det_root, i01 = -r01 * inv_det_root,
              i11 = (tr_root - r11) * inv_det_root;
      for (int c = 0; c < 3; ++c) {
        ra[c][0] = a2[c][0] * i00 + a2[c][1] * i01;
        ra[c][1] = a2[c][0] * i01 + a2[c][1] * i11;
      }
      // R n = q_a x q_b.
      ra[0][2] = ra[1][0] * ra[2][1] - ra[2][0] * ra[1][1];
      ra[1][2] = ra[2][0] * ra[0][1] - ra[0][0] * ra[2][1];
      ra[2][2] = ra[0][0] * ra[1][1] - ra[1][0] * ra[0][1];
    }
    // u_k = R^T (x_k - c) - (X_k - C), packed for the coupling.
    for (int p = 0; p < m; ++p) {
      const int s = g.slot[static_cast<std::size_t>(p)];
      for (int i = 0; i < 3; ++i)
        y[p][i] = madd(ra[2][i], d[s][2], madd(ra[1][i], d[s][1], ra[0][i] * d[s][0]));
    }
    V e = V::Zero();
    if (coupling == kInPlane || coupling == kSplit) {
      for (int p = 0; p < m; ++p)
        for (int i = 0; i < 2; ++i) u[2 * p + i] = y[p][i] - rn[p * 3 + i];
      apply_k<kPlaneN>(g.k_plane.data(), 2 * m, u, kv, e);
      for (int p = 0; p < m; ++p) {
        gl[p][0] = kv[2 * p];
        gl[p][1] = kv[2 * p + 1];
        gl[p][2] = V::Zero();
      }
    }
    if (coupling == kNormal || coupling == kSplit) {
      for (int p = 0; p < m; ++p) u[p] = y[p][2] - rn[p * 3 + 2];
      apply_k<kM>(g.k_normal.data(), m, u, kv, e);
      for (int p = 0; p < m; ++p) {
        if (coupling == kNormal) gl[p][0] = gl[p][1] = V::Zero();
        gl[p][2] = kv[p];
      }
    }
    if (coupling == kAll) {
      for (int p = 0; p < m; ++p)
        for (int i = 0; i < 3; ++i) u[3 * p + i] = y[p][i] - rn[p * 3 + i];
      apply_k<kAllN>(g.k_all.data(), 3 * m, u, kv, e);
      for (int p = 0; p < m; ++p)
        for (int i = 0; i < 3; ++i) gl[p][i] = kv[3 * p + i];
    }
    if (valid == L) {
      e_sum += e;
    } else {
      for (int l = 0; l < valid; ++l) e_sum[l] += e[l];
    }

    // -dE/dx in local axes: -g_k on the nodes, and (frame) mu x b_f + sum_k g_k / n_f:
    // dE = sum_k g_k . (RA)^T (dx_k - dc) - omega . tau,  tau = sum_k y_k x g_k (omega the
    // frame's rotation rate in local axes), and (tr S I - S) mu = tau, block diagonal in
    // local axes: the (a, b) block is tr(root) I - root = adj(root), whose inverse is
    // root / det(root); the n entry tr(root).
    for (int s = 0; s < np; ++s)
      for (int i = 0; i < 3; ++i) h[s][i] = V::Zero();
    // (With the normal coupling alone, g_k = (0, 0, g_kn): the terms of its zero components,
    // exact zeros, are left out below.)
    for (int p = 0; p < m; ++p) {
      const int s = g.slot[static_cast<std::size_t>(p)];
      if constexpr (kCoupling == kNormal) {
        h[s][2] -= gl[p][2];
      } else {
        for (int i = 0; i < 3; ++i) h[s][i] -= gl[p][i];
      }
    }
    if constexpr (kCoupling == kNormal) {
      if (nf > 0) {
        V tau0 = V::Zero(), tau1 = V::Zero(), gsum2 = V::Zero();
        for (int p = 0; p < m; ++p) {
          tau0 = madd(y[p][1], gl[p][2], tau0);
          tau1 = nmadd(y[p][0], gl[p][2], tau1);
          gsum2 += gl[p][2];
        }
        const V mu0 = (r00 * tau0 + r01 * tau1) * inv_det_root;
        const V mu1 = (r01 * tau0 + r11 * tau1) * inv_det_root;
        gsum2 *= inv_nf;
        for (int s = 0; s < nf; ++s) {
          const V* bs = rf + s * 3;
          h[s][0] = madd(mu1, bs[2], h[s][0]);
          h[s][1] = nmadd(mu0, bs[2], h[s][1]);
          h[s][2] = madd(mu0, bs[1], nmadd(mu1, bs[0], h[s][2] + gsum2));
        }
      }
    } else if (nf > 0) {
      V tau[3], gsum[3];
      for (int i = 0; i < 3; ++i) tau[i] = gsum[i] = V::Zero();
      for (int p = 0; p < m; ++p) {
        tau[0] += y[p][1] * gl[p][2] - y[p][2] * gl[p][1];
        tau[1] += y[p][2] * gl[p][0] - y[p][0] * gl[p][2];
        tau[2] += y[p][0] * gl[p][1] - y[p][1] * gl[p][0];
        for (int i = 0; i < 3; ++i) gsum[i] += gl[p][i];
      }
      const V mu0 = (r00 * tau[0] + r01 * tau[1]) * inv_det_root;
      const V mu1 = (r01 * tau[0] + r11 * tau[1]) * inv_det_root;
      const V mu2 = tau[2] * inv_tr_root;
      for (int i = 0; i < 3; ++i) gsum[i] *= inv_nf;
      for (int s = 0; s < nf; ++s) {
        const V* bs = rf + s * 3;
        h[s][0] = madd(mu1, bs[2], nmadd(mu2, bs[1], h[s][0] + gsum[0]));
        h[s][1] = madd(mu2, bs[0], nmadd(mu0, bs[2], h[s][1] + gsum[1]));
        h[s][2] = madd(mu0, bs[1], nmadd(mu1, bs[0], h[s][2] + gsum[2]));
      }
    }
    // Back to the scene's axes, into out_ (evaluate() adds them up per CGP).
    V* out = out_.data() + g.first_out + static_cast<std::size_t>(b * np * 3);
    for (int s = 0; s < np; ++s)
      for (int c = 0; c < 3; ++c)
        out[s * 3 + c] = madd(ra[c][2], h[s][2], madd(ra[c][1], h[s][1], ra[c][0] * h[s][0]));
  }
  for (int l = 0; l < L; ++l) energy += e_sum[l];  // (Eigen's sum() trips GCC 12's bug 105593)
}

}  // namespace cosim::solid
