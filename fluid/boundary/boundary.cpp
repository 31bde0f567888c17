#include "fluid/boundary/boundary.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/equilibrium.hpp"

namespace cosim::fluid {

const char* face_name(int f) {
  static const char* names[kFaces] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
  return names[f];
}

const char* kind_name(FaceKind k) {
  switch (k) {
    case FaceKind::Periodic: return "periodic";
    case FaceKind::Wall: return "wall";
    case FaceKind::FreeSlip: return "free_slip";
    case FaceKind::Inlet: return "inlet";
    case FaceKind::Outflow: return "outflow";
  }
  return "?";
}

double inlet_profile(const FaceSpec& face, double y) {
  if (face.profile == InletProfile::Parabolic) {
    if (face.channel_height <= 0.0) return face.inlet_speed;
    const double s = (y + 0.5) / face.channel_height;
    return s <= 0.0 || s >= 1.0 ? 0.0 : 4.0 * face.inlet_speed * s * (1.0 - s);
  }
  if (face.profile == InletProfile::Uniform || face.boundary_layer <= 0.0) return face.inlet_speed;
  const double e = (y + 0.5) / face.boundary_layer;
  if (e <= 0.0) return 0.0;
  if (e >= 1.0) return face.inlet_speed;
  return face.inlet_speed * (2.0 * e - 2.0 * e * e * e + e * e * e * e);
}

double inlet_ramp(double t, double T) {
  if (!(T > 0.0) || t >= T) return 1.0;
  if (t <= 0.0) return 0.0;
  return 0.5 * (1.0 - std::cos(std::numbers::pi * t / T));
}

std::string BoundaryConditions::check(const std::array<FaceSpec, kFaces>& faces,
                                      const std::array<bool, kFaces>& halo) {
  for (int a = 0; a < 3; ++a) {
    if (halo[2 * a] || halo[2 * a + 1]) continue;  // a block's edge: the neighbour's plane
    const bool p0 = faces[2 * a].kind == FaceKind::Periodic;
    const bool p1 = faces[2 * a + 1].kind == FaceKind::Periodic;
    if (p0 != p1)
      return std::string("faces ") + face_name(2 * a) + " and " + face_name(2 * a + 1) +
             " must both be periodic or neither";
  }
  for (int f = 0; f < kFaces; ++f) {
    const FaceSpec& s = faces[f];
    if (s.kind == FaceKind::Inlet && s.profile == InletProfile::Blasius && face_axis(f) == 1)
      return std::string("a Blasius inlet on ") + face_name(f) +
             " is not possible: the profile is measured from the y_min plate";
    if (s.kind == FaceKind::Inlet && s.profile == InletProfile::Parabolic && face_axis(f) != 0)
      return std::string("a parabolic inlet on ") + face_name(f) +
             " is not possible: the profile spans y between the y faces, so the inlet must be an x face";
    if (s.kind == FaceKind::Wall && s.wall_velocity[face_axis(f)] != 0.0)
      return std::string("the wall velocity on ") + face_name(f) + " must be tangential";
  }
  return {};
}

namespace {

/// The populations a face's ghost plane feeds into the domain: c along the face's axis
/// pointing inward, and of those, where `along_axis` >= 0, the ones whose c along that axis
/// is `c_along` (a wall's ghosts of a halo layer's cells: those that leave the layer towards
/// the block). The one selection of the copy faces, the walls (Eq. 14) and the free-slip faces.
struct EnteringPopulations {
  explicit EnteringPopulations(int face, int along_axis = -1, int c_along = 0) {
    const int axis = face_axis(face), inward = face_side(face) == 0 ? 1 : -1;
    for (int q = 0; q < D3Q19::Q; ++q)
      if (D3Q19::c(q, axis) == inward && (along_axis < 0 || D3Q19::c(q, along_axis) == c_along)) qs[nq++] = q;
  }
  int qs[D3Q19::Q];
  int nq = 0;
};

bool is_copy(FaceKind k) {
  return k == FaceKind::Periodic || k == FaceKind::Inlet || k == FaceKind::Outflow;
}

/// Ranges of the two axes other than `axis` for a ghost plane: axes before `axis` in the
/// fill order include their ghosts (already filled), later ones only the interior.
struct PlaneRange {
  int lo[3], hi[3];  // inclusive
};

PlaneRange plane_range(const GridLayout& L, int axis, bool all_ghosts) {
  const int n[3] = {L.nx(), L.ny(), L.nz()};
  PlaneRange r{};
  for (int b = 0; b < 3; ++b) {
    const bool ext = all_ghosts || b < axis;
    r.lo[b] = ext ? -1 : 0;
    r.hi[b] = ext ? n[b] : n[b] - 1;
  }
  if (L.wraps_z()) r.lo[2] = r.hi[2] = 0;  // its z ghosts are the plane itself
  return r;
}

/// Outflow ghost plane (see BoundaryConditions): non-equilibrium extrapolation at the
/// reference density, from the boundary cell b = g + src_off. Inside a parallel region.
///
/// The edge ghosts of a y or z outflow next to the ghosts of an axis before it (the plane
/// range includes those): b = g + src_off is then a ghost cell of that axis, whose fill
/// wrote only the populations entering the grid there, while the extrapolation reads all
/// 19. Those b are taken instead as the interior cell the earlier face's ghost stands for:
///  - periodic axis (`periodic[a]`): its image across the grid (n - 1 for -1, 0 for n), so
///    the edge ghost is the outflow ghost of the image's column, as in a wider periodic grid;
///  - inlet, outflow, wall, free slip: the nearest interior cell (0 for -1, n - 1 for n),
///    the corner's own boundary cell: the edge ghost is the outflow's extrapolation from
///    the cell it enters, as on the rest of the face. Next to a wall or free slip face the
///    pulled edge populations are written again afterwards by that face's fill (reflecting
///    faces go last), so there the choice only keeps the outflow from reading stale values.
/// Elsewhere b is g + src_off, as before.
template <class T>
void fill_outflow(const PopulationSlots<T>& f, const GridLayout& layout, int face, double rho_out,
                  const PlaneRange& r, std::ptrdiff_t src_off, const bool periodic[3]) {
  const int axis = face_axis(face);
  const int inward = face_side(face) == 0 ? 1 : -1;
  const int n[3] = {layout.nx(), layout.ny(), layout.nz()};
  // The interior coordinate an earlier axis' ghost coordinate c stands for.
  const auto inside = [&](int a, int c) {
    if (c < 0) return periodic[a] ? n[a] - 1 : 0;
    if (c >= n[a]) return periodic[a] ? 0 : n[a] - 1;
    return c;
  };
#pragma omp for collapse(2) schedule(static) nowait
  for (int z = r.lo[2]; z <= r.hi[2]; ++z)
    for (int y = r.lo[1]; y <= r.hi[1]; ++y)
      for (int x = r.lo[0]; x <= r.hi[0]; ++x) {
        const std::ptrdiff_t g = layout.index(x, y, z);
        int c[3] = {x, y, z};
        bool edge = false;
        for (int a = 0; a < axis; ++a) {
          const int ci = inside(a, c[a]);
          edge = edge || ci != c[a];
          c[a] = ci;
        }
        const std::ptrdiff_t b = edge ? layout.index(c[0], c[1], c[2]) + src_off : g + src_off;
        T stored[D3Q19::Q], ghost[D3Q19::Q];
        for (int q = 0; q < D3Q19::Q; ++q) stored[q] = f.q(q)[b];
        outflow_ghost(stored, axis, inward, rho_out, ghost);
        for (int q = 0; q < D3Q19::Q; ++q)
          if (D3Q19::c(q, axis) == inward && f.has(q, x, y, z)) f.q(q)[g] = ghost[q];
      }
}

/// The inlet ghost of population q at height y: the equilibrium (Eq. 11) at inlet_density
/// and the inlet velocity (inward along `axis`) times `scale` (the start-up ramp).
double inlet_ghost(const FaceSpec& spec, int axis, int inward, int q, int y, double scale) {
  double vel[3] = {0.0, 0.0, 0.0};
  vel[axis] = inward * scale * inlet_profile(spec, y);
  return equilibrium(q, spec.inlet_density, vel[0], vel[1], vel[2]);
}

bool is_kernel_outflow(const FaceSpec& spec, int face) {
  return spec.kind == FaceKind::Outflow && face_axis(face) == 0;
}

}  // namespace

BoundaryConditions::BoundaryConditions(const GridLayout& layout,
                                       const std::array<FaceSpec, kFaces>& faces,
                                       const std::array<bool, kFaces>& halo, int y_origin)
    : layout_(layout), faces_(faces), halo_(halo), y_origin_(y_origin) {
  const std::string err = check(faces, halo);
  if (!err.empty()) throw std::invalid_argument(err);
  if (halo[XMin] || halo[XMax])
    throw std::invalid_argument("BoundaryConditions: halo faces on x (the blocks keep the rows of x whole)");
  // An outflow's edge ghosts next to an earlier axis' ghosts extrapolate from the interior
  // cell those ghosts stand for (fill_outflow); next to halo faces that is a neighbour
  // block's cell, which the exchange does not send whole.
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if ((halo[2 * a] || halo[2 * a + 1]) &&
          (faces[2 * b].kind == FaceKind::Outflow || faces[2 * b + 1].kind == FaceKind::Outflow) &&
          !halo[2 * b] && !halo[2 * b + 1])
        throw std::invalid_argument(std::string("BoundaryConditions: an outflow on ") + face_name(2 * b) + "/" +
                                    face_name(2 * b + 1) + " next to halo faces on " + face_name(2 * a) + "/" +
                                    face_name(2 * a + 1) + " (its edge ghosts would need the neighbour block's cells)");
  // A halo face is filled by the exchange only: no fill of its own (kind Periodic is never
  // a reflecting or an inlet fill, and fills_copy() skips it).
  for (int f = 0; f < kFaces; ++f)
    if (halo[f]) faces_[f] = FaceSpec{};
  fill_inlet_x_table();
}

void BoundaryConditions::fill_inlet_x_table() {
  // The x inlets' ghosts by height, for the in-place kernel (in_place_x_faces). The vectors
  // keep their storage when filled again (set_inlet_scale): InPlaceXFaces points into them.
  for (const int face : {XMin, XMax}) {
    if (faces_[face].kind != FaceKind::Inlet) continue;
    const int inward = face_side(face) == 0 ? 1 : -1;
    std::vector<double>& t = inlet_x_ghosts_[face_side(face)];
    t.resize(std::size_t(layout_.ny()) * D3Q19::Q);
    std::fill(t.begin(), t.end(), 0.0);
    for (int y = 0; y < layout_.ny(); ++y)
      for (int q = 0; q < D3Q19::Q; ++q)
        if (D3Q19::cx[q] == inward)
          t[std::size_t(y) * D3Q19::Q + q] = inlet_ghost(faces_[face], 0, inward, q, y + y_origin_, inlet_scale_);
  }
}

void BoundaryConditions::set_inlet_scale(double s) {
  if (!std::isfinite(s)) throw std::invalid_argument("BoundaryConditions::set_inlet_scale: not a finite number");
  inlet_scale_ = s;
  fill_inlet_x_table();
}

bool BoundaryConditions::has_halo() const {
  return std::any_of(halo_.begin(), halo_.end(), [](bool h) { return h; });
}

bool BoundaryConditions::fills_copy(int face, Fill which) const {
  const FaceKind k = faces_[face].kind;
  if (halo_[face] || !is_copy(k)) return false;
  if (face_axis(face) == 2 && layout_.wraps_z()) return false;  // the plane is its own image
  if (which == Fill::AllButX) return face_axis(face) != 0;
  return which == Fill::All || (k != FaceKind::Inlet && !is_kernel_outflow(faces_[face], face));
}

template <class T>
void BoundaryConditions::fill_copy_faces(const PopulationSlots<T>& f, int from, int to, Fill which) const {
  for (int face = from; face < to; ++face)
    if (fills_copy(face, which)) {
      fill_copy_face(f, face);
#pragma omp barrier
    }
}

/// Free slip faces first, then the walls. A free slip ghost next to a wall's ghosts (their
/// shared edge) mirrors a population of the wall's ghost cell that the wall's half-way
/// fill does not write (it writes only what its interior cells bounce back); the pulled
/// populations of such an edge ghost are those entering through both faces, and the wall
/// writes every one of them (from the corner's interior cell). So the wall's fill comes
/// after and decides the edge: half-way bounce-back (Eq. 14) at a wall / free slip edge,
/// as at a wall / wall edge, a no-slip corner. Two free slip faces: the later one's edge
/// ghosts mirror populations the earlier one wrote from the interior. The order matters
/// only on such edges (no other reflecting fill reads another's ghosts).
template <class T>
void BoundaryConditions::fill_reflect_faces(const PopulationSlots<T>& f, Fill which) const {
  for (const FaceKind kind : {FaceKind::FreeSlip, FaceKind::Wall})
    for (int face = which == Fill::AllButX ? 2 : 0; face < kFaces; ++face)
      if (faces_[face].kind == kind) {
        fill_reflect_face(f, face);
#pragma omp barrier
      }
}

template <class T>
void BoundaryConditions::fill(BasicPopulationField<T>& f, HaloExchange* halo, Fill which,
                              PopulationLayout arrangement) const {
  const PopulationSlots<T> slots(f, arrangement);
  if (!has_halo()) {
    // One parallel region; the loops of a face (one per population) run without waiting for
    // each other, and one barrier after each face keeps the faces in order.
#pragma omp parallel
    {
      fill_copy_faces(slots, 0, kFaces, which);
      fill_reflect_faces(slots, which);
    }
    return;
  }
  if (arrangement != PopulationLayout::Canonical)
    throw std::logic_error("BoundaryConditions: a Swapped state's ghosts with halo faces (the exchange sends the field as it is)");
  if (halo == nullptr) throw std::logic_error("BoundaryConditions: a block with halo faces needs its exchange");
  if (halo->faces() != halo_)
    throw std::logic_error("BoundaryConditions: the halo exchange fills other faces than the conditions leave to it");
  // Axis by axis, the copy-type faces of an axis or its halo faces (a periodic copy from
  // the neighbour, in that axis' place; the other face of a halo axis, the grid's own, is
  // a reflecting one or a copy-type one filled with the axis), then the reflecting faces:
  // the order above, in parallel regions between the exchanges.
  int from = 0;
  for (int axis = 0; axis < 3; ++axis) {
    if (!halo_[2 * axis] && !halo_[2 * axis + 1]) continue;
#pragma omp parallel
    fill_copy_faces(slots, from, 2 * axis + 2, which);
    halo->exchange_axis(f, axis);
    from = 2 * axis + 2;
  }
#pragma omp parallel
  {
    fill_copy_faces(slots, from, kFaces, which);
    fill_reflect_faces(slots, which);
  }
}

template <class T>
void outflow_ghost(const T* stored, int axis, int inward, double rho_out, T* ghost) {
  double fb[D3Q19::Q];
  for (int q = 0; q < D3Q19::Q; ++q) fb[q] = decode_population(stored[q], q);
  const Moments m = moments(fb);
  const double ux = m.jx / m.rho, uy = m.jy / m.rho, uz = m.jz / m.rho;
  for (int q = 0; q < D3Q19::Q; ++q)
    if (D3Q19::c(q, axis) == inward)
      ghost[q] = encode_population<T>(equilibrium(q, rho_out, ux, uy, uz) + fb[q] -
                                          equilibrium(q, m.rho, ux, uy, uz), q);
}

template void outflow_ghost(const double*, int, int, double, double*);
template void outflow_ghost(const float*, int, int, double, float*);
template void outflow_ghost(const Half16*, int, int, double, Half16*);

template <class T>
void in_place_x_ghosts(T* c, const std::ptrdiff_t* wr, int nx, int y, const InPlaceXFaces& xf) {
  using Kind = InPlaceXFaces::Kind;
  using L = D3Q19;
  for (int side = 0; side < 2; ++side) {
    const int inward = side == 0 ? 1 : -1, gx = side == 0 ? -1 : nx, b = side == 0 ? 0 : nx - 1;
    switch (xf.kind[side]) {
      case Kind::Periodic: {
        const int from = side == 0 ? nx - 1 : 0;
        for (int q = 0; q < L::Q; ++q)
          if (L::cx[q] == inward) c[wr[q] + gx] = c[wr[q] + from];
        break;
      }
      case Kind::Outflow: {
        T stored[L::Q], ghost[L::Q];
        for (int q = 0; q < L::Q; ++q) stored[q] = c[wr[q] + b];
        outflow_ghost(stored, 0, inward, xf.rho_out[side], ghost);
        for (int q = 0; q < L::Q; ++q)
          if (L::cx[q] == inward) c[wr[q] + gx] = ghost[q];
        break;
      }
      case Kind::Inlet: {
        const double* const v = xf.inlet[side] + std::ptrdiff_t(y) * L::Q;
        for (int q = 0; q < L::Q; ++q)
          if (L::cx[q] == inward) c[wr[q] + gx] = encode_population<T>(v[q], q);
        break;
      }
      case Kind::Other:
        break;
    }
  }
}

template void in_place_x_ghosts(double*, const std::ptrdiff_t*, int, int, const InPlaceXFaces&);
template void in_place_x_ghosts(float*, const std::ptrdiff_t*, int, int, const InPlaceXFaces&);
template void in_place_x_ghosts(Half16*, const std::ptrdiff_t*, int, int, const InPlaceXFaces&);

template <class T>
void BoundaryConditions::fill_ghosts(BasicPopulationField<T>& f, HaloExchange* halo) const {
  fill(f, halo, Fill::All);
}

template <class T>
void BoundaryConditions::fill_ghosts_but_x(BasicPopulationField<T>& f, HaloExchange* halo) const {
  fill(f, halo, Fill::AllButX);
}

template <class T>
void BoundaryConditions::fill_swapped_ghosts(BasicPopulationField<T>& f, bool x_faces) const {
  fill(f, nullptr, x_faces ? Fill::All : Fill::AllButX, PopulationLayout::Swapped);
}

InPlaceXFaces BoundaryConditions::in_place_x_faces() const {
  InPlaceXFaces k;
  for (const int face : {XMin, XMax}) {
    const FaceSpec& spec = faces_[face];
    const int side = face_side(face);
    if (halo_[face]) continue;  // Other
    if (spec.kind == FaceKind::Periodic) k.kind[side] = InPlaceXFaces::Kind::Periodic;
    if (spec.kind == FaceKind::Outflow) k.kind[side] = InPlaceXFaces::Kind::Outflow;
    k.rho_out[side] = spec.outflow_density;
    if (spec.kind == FaceKind::Inlet) {
      k.kind[side] = InPlaceXFaces::Kind::Inlet;
      k.inlet[side] = inlet_x_ghosts_[side].data();
    }
  }
  return k;
}

template <class T>
void BoundaryConditions::fill_static_ghosts(BasicPopulationField<T>& f) const {
  const PopulationSlots<T> slots(f, PopulationLayout::Canonical);
#pragma omp parallel
  for (int face = 0; face < kFaces; ++face)
    if (faces_[face].kind == FaceKind::Inlet) {
      fill_copy_face(slots, face);
#pragma omp barrier
    }
}

template <class T>
void BoundaryConditions::fill_step_ghosts(BasicPopulationField<T>& f, HaloExchange* halo) const {
  fill(f, halo, Fill::Step);
}

template <class T>
void BoundaryConditions::fill_wall_ghosts_of_halo_cells(BasicPopulationField<T>& f,
                                                        const std::array<bool, kFaces>& cells) const {
  const PopulationSlots<T> slots(f, PopulationLayout::Canonical);
  // The faces in fill_reflect_faces' order (walls after free slip: a wall's ghost is its
  // own). The populations whose ghost lies in this block: those that leave the halo layer
  // towards it (c = -1 from the layer below, +1 from the one above).
#pragma omp parallel
  for (int face = XMin; face < kFaces; ++face) {
    if (faces_[face].kind != FaceKind::Wall || halo_[face]) continue;
    for (int h = YMin; h < kFaces; ++h)
      if (halo_[h] && cells[h] && face_axis(h) != face_axis(face)) {
        fill_wall(slots, face, h, face_side(h) == 0 ? -1 : 1);
#pragma omp barrier
      }
  }
}

KernelOutflow BoundaryConditions::kernel_outflow() const {
  KernelOutflow k;
  k.x_min = is_kernel_outflow(faces_[XMin], XMin);
  k.x_max = is_kernel_outflow(faces_[XMax], XMax);
  k.rho_x_min = faces_[XMin].outflow_density;
  k.rho_x_max = faces_[XMax].outflow_density;
  k.keep_x_max_ghosts = faces_[XMax].kind == FaceKind::Inlet;  // fill_static_ghosts wrote them
  return k;
}

template <class T>
void BoundaryConditions::fill_outflow_ghost(BasicPopulationField<T>& f, int x, int y, int z) const {
  for (const int face : {XMin, XMax}) {
    if (!is_kernel_outflow(faces_[face], face)) continue;
    const int side = face_side(face), inward = side == 0 ? 1 : -1;
    if (x != (side == 0 ? 0 : layout_.nx() - 1)) continue;
    const std::ptrdiff_t b = layout_.index(x, y, z), g = b - inward;
    T stored[D3Q19::Q], ghost[D3Q19::Q];
    for (int q = 0; q < D3Q19::Q; ++q) stored[q] = f.q(q)[b];
    outflow_ghost(stored, 0, inward, faces_[face].outflow_density, ghost);
    for (int q = 0; q < D3Q19::Q; ++q)
      if (D3Q19::cx[q] == inward) f.q(q)[g] = ghost[q];
  }
}

template <class T>
void BoundaryConditions::fill_copy_face(const PopulationSlots<T>& f, int face) const {
  const FaceSpec& spec = faces_[face];
  const int axis = face_axis(face), side = face_side(face);
  const int n[3] = {layout_.nx(), layout_.ny(), layout_.nz()};
  const int ghost = side == 0 ? -1 : n[axis];
  const int inward = side == 0 ? 1 : -1;  // direction into the domain along axis
  PlaneRange r = plane_range(layout_, axis, false);
  r.lo[axis] = r.hi[axis] = ghost;

  // Populations pulled from this ghost plane into the interior.
  const EnteringPopulations entering(face);
  const int* const qs = entering.qs;
  const int nq = entering.nq;

  // Source cell for copy-type fills.
  int src_shift[3] = {0, 0, 0};
  if (spec.kind == FaceKind::Periodic) src_shift[axis] = side == 0 ? n[axis] : -n[axis];
  if (spec.kind == FaceKind::Outflow) src_shift[axis] = inward;
  const std::ptrdiff_t src_off = layout_.offset(src_shift[0], src_shift[1], src_shift[2]);
  if (spec.kind == FaceKind::Outflow) {
    const bool periodic[3] = {faces_[XMin].kind == FaceKind::Periodic && !halo_[XMin],
                              faces_[YMin].kind == FaceKind::Periodic && !halo_[YMin],
                              faces_[ZMin].kind == FaceKind::Periodic && !halo_[ZMin]};
    fill_outflow(f, layout_, face, spec.outflow_density, r, src_off, periodic);
    return;
  }

  // One row of the plane at a time, each population's part of it one contiguous copy (the
  // rows along x; an x face's rows are one cell long).
#pragma omp for collapse(2) schedule(static) nowait
  for (int z = r.lo[2]; z <= r.hi[2]; ++z)
    for (int y = r.lo[1]; y <= r.hi[1]; ++y) {
      for (int i = 0; i < nq; ++i) {
        int lo = r.lo[0], hi = r.hi[0];
        if (!f.clip(qs[i], lo, hi, y, z)) continue;
        const std::ptrdiff_t len = hi - lo + 1;
        T* const fq = f.q(qs[i]) + layout_.index(lo, y, z);
        if (spec.kind == FaceKind::Inlet)
          std::fill_n(fq, len,
                      encode_population<T>(inlet_ghost(spec, axis, inward, qs[i], y + y_origin_, inlet_scale_), qs[i]));
        else  // Periodic: source and ghost rows are n[axis] cells apart, never overlapping
          std::copy_n(fq + src_off, len, fq);
      }
    }
}

template <class T>
void BoundaryConditions::fill_wall(const PopulationSlots<T>& f, int face, int cells_of, int c_along) const {
  // For every interior cell next to the wall and every population entering from the
  // wall: ghost at x - c_q holds f*_opp(x) + 6 E_q rho_w c_q.U_w (Eq. 14), rho_w = 1.
  const FaceSpec& spec = faces_[face];
  const int axis = face_axis(face), side = face_side(face);
  const int n[3] = {layout_.nx(), layout_.ny(), layout_.nz()};
  const int c_axis = cells_of < 0 ? -1 : face_axis(cells_of);
  const EnteringPopulations entering(face, c_axis, c_along);
  PlaneRange r = plane_range(layout_, axis, false);
  for (int b = 0; b < 3; ++b)
    if (b != axis) r.lo[b] = 0, r.hi[b] = n[b] - 1;
  r.lo[axis] = r.hi[axis] = side == 0 ? 0 : n[axis] - 1;
  if (c_axis >= 0)  // the boundary cells of the halo layer: the neighbour block's
    r.lo[c_axis] = r.hi[c_axis] = face_side(cells_of) == 0 ? -1 : n[c_axis];
  const auto& U = spec.wall_velocity;
  for (int i = 0; i < entering.nq; ++i) {
    const int q = entering.qs[i], o = D3Q19::opp[q];
    const double moving = 6.0 * D3Q19::w[q] *
                          (D3Q19::cx[q] * U[0] + D3Q19::cy[q] * U[1] + D3Q19::cz[q] * U[2]);
    const std::ptrdiff_t back = layout_.offset(-D3Q19::cx[q], -D3Q19::cy[q], -D3Q19::cz[q]);
    T* fq = f.q(q);
    const T* fo = f.q(o);
#pragma omp for collapse(2) schedule(static) nowait
    for (int z = r.lo[2]; z <= r.hi[2]; ++z)
      for (int y = r.lo[1]; y <= r.hi[1]; ++y)
        for (int x = r.lo[0]; x <= r.hi[0]; ++x) {
          const std::ptrdiff_t c = layout_.index(x, y, z);
          fq[c + back] = encode_population<T>(decode_population(fo[c], o) + moving, q);
        }
  }
}

template <class T>
void BoundaryConditions::fill_reflect_face(const PopulationSlots<T>& f, int face) const {
  const FaceSpec& spec = faces_[face];
  const int axis = face_axis(face), side = face_side(face);
  const int n[3] = {layout_.nx(), layout_.ny(), layout_.nz()};
  const int inward = side == 0 ? 1 : -1;

  if (spec.kind == FaceKind::Wall) {
    fill_wall(f, face, -1, 0);
  } else {  // FreeSlip
    PlaneRange r = plane_range(layout_, axis, true);
    r.lo[axis] = r.hi[axis] = side == 0 ? -1 : n[axis];
    int in[3] = {0, 0, 0};
    in[axis] = inward;
    const std::ptrdiff_t in_off = layout_.offset(in[0], in[1], in[2]);
    const EnteringPopulations entering(face);
    for (int i = 0; i < entering.nq; ++i) {
      const int q = entering.qs[i], m = D3Q19::mirror(q, axis);
      T* fq = f.q(q);
      const T* fm = f.q(m);
#pragma omp for collapse(2) schedule(static) nowait
      for (int z = r.lo[2]; z <= r.hi[2]; ++z)
        for (int y = r.lo[1]; y <= r.hi[1]; ++y) {
          int lo = r.lo[0], hi = r.hi[0];
          if (!f.clip(q, lo, hi, y, z)) continue;
          for (int x = lo; x <= hi; ++x) {
            const std::ptrdiff_t g = layout_.index(x, y, z);
            fq[g] = fm[g + in_off];
          }
        }
    }
  }
}

template void BoundaryConditions::fill_ghosts(PopulationField&, HaloExchange*) const;
template void BoundaryConditions::fill_ghosts_but_x(PopulationField&, HaloExchange*) const;
template void BoundaryConditions::fill_swapped_ghosts(PopulationField&, bool) const;
template void BoundaryConditions::fill_swapped_ghosts(PopulationFieldSingle&, bool) const;
template void BoundaryConditions::fill_ghosts_but_x(PopulationFieldSingle&, HaloExchange*) const;
template void BoundaryConditions::fill_static_ghosts(PopulationField&) const;
template void BoundaryConditions::fill_step_ghosts(PopulationField&, HaloExchange*) const;
template void BoundaryConditions::fill_outflow_ghost(PopulationField&, int, int, int) const;
template void BoundaryConditions::fill_wall_ghosts_of_halo_cells(PopulationField&, const std::array<bool, kFaces>&) const;
template void BoundaryConditions::fill_ghosts(PopulationFieldSingle&, HaloExchange*) const;
template void BoundaryConditions::fill_static_ghosts(PopulationFieldSingle&) const;
template void BoundaryConditions::fill_step_ghosts(PopulationFieldSingle&, HaloExchange*) const;
template void BoundaryConditions::fill_outflow_ghost(PopulationFieldSingle&, int, int, int) const;
template void BoundaryConditions::fill_wall_ghosts_of_halo_cells(PopulationFieldSingle&, const std::array<bool, kFaces>&) const;
template void BoundaryConditions::fill_ghosts(PopulationFieldHalf&, HaloExchange*) const;
template void BoundaryConditions::fill_ghosts_but_x(PopulationFieldHalf&, HaloExchange*) const;
template void BoundaryConditions::fill_swapped_ghosts(PopulationFieldHalf&, bool) const;
template void BoundaryConditions::fill_static_ghosts(PopulationFieldHalf&) const;
template void BoundaryConditions::fill_step_ghosts(PopulationFieldHalf&, HaloExchange*) const;
template void BoundaryConditions::fill_outflow_ghost(PopulationFieldHalf&, int, int, int) const;
template void BoundaryConditions::fill_wall_ghosts_of_halo_cells(PopulationFieldHalf&, const std::array<bool, kFaces>&) const;

}  // namespace cosim::fluid
