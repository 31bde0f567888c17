#include "fluid/ib/held_body.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace cosim::fluid {

namespace {

/// Markers along the segment a -> b (z = 0) at about `spacing`, each in the middle of its
/// piece, with the piece's length as its element.
void segment_markers(double ax, double ay, double bx, double by, double spacing, std::vector<Vec3>& X,
                     std::vector<double>& area) {
  const double length = std::hypot(bx - ax, by - ay);
  if (!(length > 0.0)) return;
  const int n = std::max(1, int(std::ceil(length / spacing - 1e-9)));
  for (int i = 0; i < n; ++i) {
    const double s = (i + 0.5) / n;
    X.push_back({ax + s * (bx - ax), ay + s * (by - ay), 0.0});
    area.push_back(length / n);
  }
}

}  // namespace

void held_body_markers(const HeldBodyShape& b, int nz, std::vector<Vec3>& X, std::vector<double>& area) {
  X.clear();
  area.clear();
  std::vector<Vec3> ring;
  std::vector<double> ring_area;
  const double R = b.radius - b.retraction;
  const bool bar = b.bar_thickness > 0.0;
  const double half = 0.5 * b.bar_thickness - b.retraction;  // the retracted bar's half thickness
  const double tip = b.bar_tip_x - b.retraction;
  // The cylinder: a ring, without the markers inside the bar (its root lies in the cylinder).
  const int N = std::max(3, int(std::ceil(2.0 * std::numbers::pi * R / b.spacing)));
  for (int l = 0; l < N; ++l) {
    const double th = 2.0 * std::numbers::pi * (l + 0.5) / N;
    const double x = b.x_c + R * std::cos(th), y = b.y_c + R * std::sin(th);
    if (bar && half > 0.0 && x > b.x_c && std::abs(y - b.y_c) < half) continue;
    ring.push_back({x, y, 0.0});
    ring_area.push_back(2.0 * std::numbers::pi * R / N);
  }
  // The bar: top and bottom from where they leave the ring, and the tip.
  if (bar && half > 0.0 && half < R && tip > b.x_c) {
    const double x0 = b.x_c + std::sqrt(R * R - half * half);
    if (tip > x0) {
      segment_markers(x0, b.y_c + half, tip, b.y_c + half, b.spacing, ring, ring_area);
      segment_markers(x0, b.y_c - half, tip, b.y_c - half, b.spacing, ring, ring_area);
      segment_markers(tip, b.y_c - half, tip, b.y_c + half, b.spacing, ring, ring_area);
    }
  }
  for (int k = 0; k < nz; ++k)
    for (std::size_t l = 0; l < ring.size(); ++l) {
      X.push_back({ring[l][0], ring[l][1], double(k)});
      area.push_back(ring_area[l]);
    }
}

HeldBody::HeldBody(const HeldBodyShape& shape, const ImmersedBoundary& ib) : shape_(shape) {
  if (!(shape.radius > 0.0)) throw std::invalid_argument("HeldBody: radius must be > 0");
  if (shape.iterations < 1) throw std::invalid_argument("HeldBody: iterations must be >= 1");
  held_body_markers(shape, ib.shape().nz, X_, area_);
  if (X_.empty()) throw std::invalid_argument("HeldBody: the shape has no markers");
  // The sparse rows: each distinct node once.
  std::unordered_map<long long, std::size_t> index;
  const GridShape& g = ib.shape();
  first_.push_back(0);
  for (const Vec3& X : X_) {
    ib.for_each_node(X, [&](int x, int y, int z, double D) {
      const long long key = (static_cast<long long>(z) * g.ny + y) * g.nx + x;
      const auto [it, added] = index.try_emplace(key, index.size());
      node_.push_back(it->second);
      weight_.push_back(D);
    });
    first_.push_back(node_.size());
  }
  nodes_ = index.size();
}

const std::vector<Vec3>& HeldBody::impulses(std::span<const MarkerSample> s) {
  const std::size_t n = X_.size();
  if (s.size() != n)
    throw std::invalid_argument("HeldBody::impulses: " + std::to_string(s.size()) + " samples for " +
                                std::to_string(n) + " markers");
  J_.assign(n, Vec3{0.0, 0.0, 0.0});
  dJ_.resize(n);
  u_.resize(n);
  rho_.resize(n);
  for (std::size_t l = 0; l < n; ++l) {
    // rho_l of Eq. 17 is a partial sum where the kernel crosses a wall: the mean it sees.
    rho_[l] = s[l].weight > 0.0 ? s[l].rho / s[l].weight : 1.0;
    u_[l] = s[l].u;
  }
  const Vec3 rest{0.0, 0.0, 0.0};
  for (int pass = 0; pass < shape_.iterations; ++pass) {
    for (std::size_t l = 0; l < n; ++l) {
      dJ_[l] = momentum_exchange_force(rho_[l], u_[l], rest);  // DESIGN 2.1, U_B = 0
      for (int c = 0; c < 3; ++c) {
        dJ_[l][c] *= area_[l];
        J_[l][c] += dJ_[l][c];
      }
    }
    if (pass + 1 == shape_.iterations) break;
    // The velocity these impulses leave at the markers: spread (Eq. 21), Guo's half-force
    // shift u' = u + F / (2 rho) at the nodes, interpolated back (Eq. 17).
    node_force_.assign(nodes_, Vec3{0.0, 0.0, 0.0});
    for (std::size_t l = 0; l < n; ++l)
      for (std::size_t e = first_[l]; e < first_[l + 1]; ++e)
        for (int c = 0; c < 3; ++c) node_force_[node_[e]][c] += weight_[e] * dJ_[l][c];
    for (std::size_t l = 0; l < n; ++l) {
      Vec3 du{0.0, 0.0, 0.0};
      for (std::size_t e = first_[l]; e < first_[l + 1]; ++e)
        for (int c = 0; c < 3; ++c) du[c] += weight_[e] * node_force_[node_[e]][c];
      for (int c = 0; c < 3; ++c) u_[l][c] += du[c] / (2.0 * rho_[l]);
    }
  }
  force_ = {0.0, 0.0, 0.0};
  for (const Vec3& j : J_)
    for (int c = 0; c < 3; ++c) force_[c] -= j[c];  // the body receives -J
  return J_;
}

}  // namespace cosim::fluid
