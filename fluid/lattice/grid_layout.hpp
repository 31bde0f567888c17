// Index arithmetic of the structure-of-arrays population storage with one ghost layer.
#pragma once

#include <cstddef>
#include <cstdint>

namespace cosim::fluid {

/// Interior size of a block of the lattice, in cells.
struct GridShape {
  int nx = 0, ny = 0, nz = 0;
  std::int64_t cells() const { return std::int64_t(nx) * ny * nz; }
};

/// Layout of one population array: x fastest, one ghost layer on every face, rows padded
/// so that the interior cell x = 0 of every row sits on a 64-byte boundary (aligned vector
/// stores, whole cache lines for the non-temporal ones). Interior coordinates run 0..n-1,
/// ghosts are -1 and n. Offsets count values: 8 per 64-byte line for the double store, 16
/// for the single one (values_per_line).
///
/// The ghost layer is also what makes the grid decomposable into blocks (DESIGN 8): a
/// neighbour block's halo is one more kind of ghost fill.
class GridLayout {
 public:
  static constexpr int kLineBytes = 64;

  GridLayout() = default;
  explicit GridLayout(GridShape s, int values_per_line = kLineBytes / 8)
      : shape_(s),
        align_(values_per_line),
        sx_(row_values(s.nx, values_per_line)),
        sy_(s.ny + 2),
        sz_(s.nz + 2) {}

  const GridShape& shape() const { return shape_; }
  int nx() const { return shape_.nx; }
  int ny() const { return shape_.ny; }
  int nz() const { return shape_.nz; }
  /// Values per 64-byte line; also the padding in front of x = -1 ... x = 0 of a row.
  int values_per_line() const { return align_; }
  int front_pad() const { return align_; }

  /// Allocated entries of one population: an odd number of 64-byte lines, so that the 19
  /// populations of a cell sit on 19 different line offsets within a 4 KiB page (fewer
  /// 4K-aliasing and cache-set conflicts between the kernel's streams; docs/performance.md).
  std::size_t stride() const {
    if (view_stride_ != 0) return view_stride_;
    // The compact rows (row_values) need one line more after the last row for its x = nx.
    const std::size_t tail = compact_rows(shape_.nx, align_) ? 1 : 0;
    const std::size_t lines = std::size_t(sx_) * sy_ * sz_ / align_ + tail;
    return (lines | 1) * align_;
  }
  /// The layout of `nz` consecutive planes of this one seen as a block of their own, with
  /// this layout's stride between populations: for a view of those planes in place
  /// (BasicPopulationField::planes), e.g. a kernel run over part of a block.
  GridLayout planes(int nz) const {
    GridLayout l(GridShape{shape_.nx, shape_.ny, nz}, align_);
    l.view_stride_ = stride();
    return l;
  }
  std::ptrdiff_t row_stride() const { return sx_; }
  std::ptrdiff_t plane_stride() const { return std::ptrdiff_t(sx_) * sy_; }

  /// A grid one cell thick along z and periodic there (a two-dimensional flow): its z
  /// ghost planes are the plane itself, so that index() and offset() map every z onto
  /// z = 0. Its image across a periodic z face is the plane itself, so a pull from a z
  /// ghost reads what the periodic fill would have copied there, without the copy (two
  /// planes of populations every step, a third of the memory traffic of such a grid).
  /// The two ghost planes stay allocated and unused: the stride, and with it the size of
  /// a checkpoint, is that of the same grid without the wrap. A row loop over z ghosts
  /// visits the plane again; fills and kernels therefore take z from 0 to nz - 1 here
  /// (plane_range).
  GridLayout wrapped_z() const {
    GridLayout l = *this;
    l.wraps_z_ = true;
    return l;
  }
  bool wraps_z() const { return wraps_z_; }

  /// Offset of cell (x, y, z); ghosts included (-1 <= x <= nx, ...).
  std::ptrdiff_t index(int x, int y, int z) const {
    return (std::ptrdiff_t(wraps_z_ ? 1 : z + 1) * sy_ + (y + 1)) * sx_ + align_ + x;
  }
  /// Offset of a lattice vector (dx, dy, dz).
  std::ptrdiff_t offset(int dx, int dy, int dz) const {
    return (std::ptrdiff_t(wraps_z_ ? 0 : dz) * sy_ + dy) * sx_ + dx;
  }

 private:
  static int round_up(int v, int m) { return (v + m - 1) / m * m; }
  /// Values from one row's x = 0 to the next's. A row needs nx + 2 (two ghosts); the x = nx
  /// ghost may share a line with the next row's x = -1 ghost, so nx + 2 rounded up to whole
  /// lines is enough, and the single store takes that (half the double store's bytes on
  /// small grids too) where the row's interior ends on a line boundary or one value before
  /// it (nx % 16 = 0 or 15). Otherwise the row's last line, partly interior, would hold the
  /// next row's x = -1 ghost too; the kernel writes that line whole with one non-temporal
  /// store (fluid/collision/stream_collide.cpp), so it takes the padded row below, whose last line is
  /// its own. The double store always pads (its first layout), so that its checkpoints keep
  /// their size.
  static bool compact_rows(int nx, int per_line) {
    return per_line != kLineBytes / 8 && (nx % per_line == 0 || nx % per_line == per_line - 1);
  }
  static int row_values(int nx, int per_line) {
    return compact_rows(nx, per_line) ? round_up(nx + 2, per_line)
                                      : round_up(per_line + nx + 1, per_line);
  }
  GridShape shape_;
  int align_ = kLineBytes / 8;
  int sx_ = 0, sy_ = 0, sz_ = 0;
  std::size_t view_stride_ = 0;  ///< planes(): the stride of the layout they are part of
  bool wraps_z_ = false;         ///< wrapped_z()
};

}  // namespace cosim::fluid
