#include "solid/contact/lj_contact.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace cosim::solid {

namespace {

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

/// Pair energy and the factor g with F_i = g r_ij (section 3.2 of the paper), for
/// r^2 < sigma^2: with q = (s/r)^6, U = 4 eps (q^2 - q) and
/// (4 eps / s) {12 (s/r)^13 - 6 (s/r)^7} / r = 24 eps (2 q^2 - q) / r^2.
/// Powers of s^2 / r^2 avoid a square root per pair.
struct PairTerm {
  double energy;
  double g;
};

PairTerm lj_pair(double r2, double epsilon, double sigma2) {
  const double inv_r2 = 1.0 / r2;
  const double s2 = sigma2 * inv_r2;
  const double q = s2 * s2 * s2;
  return {4.0 * epsilon * (q * q - q), 24.0 * epsilon * (2.0 * q * q - q) * inv_r2};
}

}  // namespace

LjContact::LjContact(std::vector<int> sheet_of_cgp, double epsilon_hartree, double sigma_bohr,
                     double skin_bohr)
    : sheet_(std::move(sheet_of_cgp)),
      epsilon_(epsilon_hartree),
      sigma_(sigma_bohr),
      skin_(skin_bohr),
      min_r2_(std::numeric_limits<double>::infinity()) {
  if (sheet_.empty())
    fail(__LINE__, "the contact model needs at least one CGP; got an empty sheet_of_cgp");
  if (!(epsilon_ > 0.0) || !std::isfinite(epsilon_))
    fail(__LINE__, "the contact energy eps must be positive and finite; got epsilon_hartree = " +
                       std::to_string(epsilon_));
  if (!(sigma_ > 0.0) || !std::isfinite(sigma_))
    fail(__LINE__, "the contact cut-off sigma must be positive and finite; got sigma_bohr = " +
                       std::to_string(sigma_));
  if (!(skin_ >= 0.0) || !std::isfinite(skin_))
    fail(__LINE__, "the neighbour-list skin must be finite and >= 0; got skin_bohr = " +
                       std::to_string(skin_));
}

double LjContact::min_distance_bohr() const { return std::sqrt(min_r2_); }

void LjContact::reset_min_distance() { min_r2_ = std::numeric_limits<double>::infinity(); }

void LjContact::check_shape(const Eigen::Matrix3Xd& m, const char* what, int line) const {
  if (m.cols() != num_cgps())
    fail(line, std::string(what) + " has " + std::to_string(m.cols()) +
                   " columns; the contact model was built for " + std::to_string(num_cgps()) +
                   " CGPs");
}

bool LjContact::list_valid_for(const Eigen::Matrix3Xd& x) const {
  if (x_built_.cols() != x.cols()) return false;
  // Each CGP within skin / 2 of its build position keeps every pair now closer than sigma
  // within sigma + skin at the build (triangle inequality), i.e. on the list. Written as
  // !(d2 <= limit) so that a NaN position forces a rebuild, which reports it.
  const double limit = 0.25 * skin_ * skin_;
  for (Eigen::Index l = 0; l < x.cols(); ++l)
    if (!((x.col(l) - x_built_.col(l)).squaredNorm() <= limit)) return false;
  return true;
}

std::vector<LjContact::Pair> LjContact::find_pairs(const Eigen::Matrix3Xd& x,
                                                   double range) const {
  if (!x.allFinite())
    fail(__LINE__, "the contact model got a non-finite CGP position; positions must be finite");
  const Eigen::Index n = x.cols();
  const Eigen::Vector3d lo = x.rowwise().minCoeff();
  const Eigen::Vector3d extent = x.rowwise().maxCoeff() - lo;

  // Cells at least `range` wide, so a pair in range lies in the same or adjacent cells.
  // Their number is capped near the CGP count: far-apart sheets with a small cut-off would
  // otherwise ask for a huge, nearly empty grid; wider cells only cost a few more tests.
  // The cells are a hair wider than `range`, so that rounding in a cell index cannot put
  // two CGPs just under `range` apart two cells apart.
  const double max_cells = 2.0 * static_cast<double>(n) + 8.0;
  const double min_width = range * (1.0 + 1e-9);
  std::array<double, 3> cells{};
  for (int d = 0; d < 3; ++d)
    cells[d] = std::clamp(std::floor(extent[d] / min_width), 1.0, max_cells);
  while (cells[0] * cells[1] * cells[2] > max_cells) {
    const auto widest = std::max_element(cells.begin(), cells.end());
    *widest = std::max(1.0, std::floor(0.5 * *widest));
  }
  std::array<Eigen::Index, 3> nc{};
  std::array<double, 3> inv_width{};
  for (int d = 0; d < 3; ++d) {
    nc[d] = static_cast<Eigen::Index>(cells[d]);
    inv_width[d] = extent[d] > 0.0 ? cells[d] / extent[d] : 0.0;
  }
  auto cell_coord = [&](Eigen::Index l, int d) {
    const auto c = static_cast<Eigen::Index>(std::floor((x(d, l) - lo[d]) * inv_width[d]));
    return std::min(c, nc[d] - 1);  // the top face belongs to the last cell
  };

  // Counting sort of the CGPs by cell; within a cell they stay in ascending index order.
  using Size = std::size_t;
  const Eigen::Index num_cells = nc[0] * nc[1] * nc[2];
  std::vector<Eigen::Index> cell_of(static_cast<Size>(n));
  std::vector<Size> start(static_cast<Size>(num_cells) + 1, 0);
  for (Eigen::Index l = 0; l < n; ++l) {
    const Eigen::Index c =
        (cell_coord(l, 2) * nc[1] + cell_coord(l, 1)) * nc[0] + cell_coord(l, 0);
    cell_of[static_cast<Size>(l)] = c;
    ++start[static_cast<Size>(c) + 1];
  }
  for (Size c = 0; c + 1 < start.size(); ++c) start[c + 1] += start[c];
  std::vector<Eigen::Index> members(static_cast<Size>(n));
  {
    std::vector<Size> next(start.begin(), start.end() - 1);
    for (Eigen::Index l = 0; l < n; ++l)
      members[next[static_cast<Size>(cell_of[static_cast<Size>(l)])]++] = l;
  }

  const double range2 = range * range;
  std::vector<Pair> pairs;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Size first_of_i = pairs.size();
    const int sheet_i = sheet_[static_cast<Size>(i)];
    const Eigen::Index ci = cell_of[static_cast<Size>(i)];
    const std::array<Eigen::Index, 3> c{ci % nc[0], (ci / nc[0]) % nc[1], ci / (nc[0] * nc[1])};
    std::array<Eigen::Index, 3> from{}, to{};
    for (int d = 0; d < 3; ++d) {
      from[d] = std::max<Eigen::Index>(c[d] - 1, 0);
      to[d] = std::min(c[d] + 1, nc[d] - 1);
    }
    for (Eigen::Index cz = from[2]; cz <= to[2]; ++cz)
      for (Eigen::Index cy = from[1]; cy <= to[1]; ++cy)
        for (Eigen::Index cx = from[0]; cx <= to[0]; ++cx) {
          const auto cell = static_cast<Size>((cz * nc[1] + cy) * nc[0] + cx);
          for (Size m = start[cell]; m < start[cell + 1]; ++m) {
            const Eigen::Index j = members[m];
            // j > i takes each pair once; pairs on one sheet are the elastic model's.
            if (j <= i || sheet_[static_cast<Size>(j)] == sheet_i) continue;
            if ((x.col(i) - x.col(j)).squaredNorm() < range2) pairs.push_back({i, j});
          }
        }
    // The cells are visited in grid order; ascending j makes the summation order, and so
    // the rounding, independent of the binning.
    std::sort(pairs.begin() + static_cast<std::ptrdiff_t>(first_of_i), pairs.end(),
              [](const Pair& p, const Pair& q) { return p.j < q.j; });
  }
  return pairs;
}

double LjContact::add_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& f) {
  check_shape(x, "the position array", __LINE__);
  check_shape(f, "the force array", __LINE__);
  if (!list_valid_for(x)) {
    pairs_ = find_pairs(x, sigma_ + skin_);
    x_built_ = x;
    ++rebuilds_;
  }
  const double sigma2 = sigma_ * sigma_;
  double energy = 0.0;
  std::size_t in_cutoff = 0;
  for (const Pair& p : pairs_) {
    const Eigen::Vector3d r = x.col(p.i) - x.col(p.j);
    const double r2 = r.squaredNorm();
    min_r2_ = std::min(min_r2_, r2);
    if (!(r2 < sigma2)) continue;
    const PairTerm t = lj_pair(r2, epsilon_, sigma2);
    f.col(p.i) += t.g * r;
    f.col(p.j) -= t.g * r;
    energy += t.energy;
    ++in_cutoff;
  }
  pairs_in_cutoff_ = in_cutoff;
  return energy;
}

double LjContact::energy(const Eigen::Matrix3Xd& x) const {
  check_shape(x, "the position array", __LINE__);
  std::vector<Pair> fresh;
  const bool valid = list_valid_for(x);
  if (!valid) fresh = find_pairs(x, sigma_);
  const double sigma2 = sigma_ * sigma_;
  double energy = 0.0;
  for (const Pair& p : valid ? pairs_ : fresh) {
    const double r2 = (x.col(p.i) - x.col(p.j)).squaredNorm();
    if (r2 < sigma2) energy += lj_pair(r2, epsilon_, sigma2).energy;
  }
  return energy;
}

}  // namespace cosim::solid
