// Boundary conditions of the lattice block as ghost-layer fills (DESIGN 4.1).
#pragma once

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "fluid/lattice/equilibrium.hpp"
#include "fluid/lattice/grid_layout.hpp"
#include "fluid/domain/halo_exchange.hpp"
#include "fluid/lattice/population_field.hpp"
#include "fluid/collision/stream_collide.hpp"

namespace cosim::fluid {

enum class FaceKind { Periodic, Wall, FreeSlip, Inlet, Outflow };
enum class InletProfile { Uniform, Blasius, Parabolic };

/// Faces in the order x_min, x_max, y_min, y_max, z_min, z_max.
enum Face : int { XMin = 0, XMax, YMin, YMax, ZMin, ZMax };
constexpr int kFaces = kHaloFaces;
constexpr int face_axis(int f) { return f / 2; }
constexpr int face_side(int f) { return f % 2; }  ///< 0: min, 1: max

const char* face_name(int f);
const char* kind_name(FaceKind k);

/// What happens on one face. Lattice units throughout.
struct FaceSpec {
  FaceKind kind = FaceKind::Periodic;
  /// Wall: velocity of the wall (tangential; Ladd's moving-wall bounce-back, Eq. 14).
  std::array<double, 3> wall_velocity{0.0, 0.0, 0.0};
  /// Inlet: speed into the domain, profile, and for Blasius the layer thickness delta in
  /// cells, measured from the y_min plate (the half-way wall at y = -1/2). Parabolic: the
  /// channel's Poiseuille profile between walls at y = -1/2 and ny - 1/2, inlet_speed its
  /// peak (the mean is 2/3 of it); `channel_height` = ny (cells).
  double inlet_speed = 0.0;
  InletProfile profile = InletProfile::Uniform;
  double boundary_layer = 0.0;
  double channel_height = 0.0;
  double inlet_density = 1.0;
  /// Outflow: reference density (pressure p = rho c_s^2) held at the outflow face.
  double outflow_density = 1.0;
};

/// Inlet speed at height y (cells, cell centres at integer y) for a Blasius-type profile:
/// zero at the plate, uniform above delta. Pohlhausen's quartic approximation of the
/// Blasius layer, U (2 e - 2 e^3 + e^4) with e = (y + 1/2) / delta, smooth (C^2 at e = 1).
/// Parabolic: U 4 s (1 - s) with s = (y + 1/2) / channel_height, zero on both half-way walls
/// (Turek and Hron's inlet, u(0, y) = 1.5 U_mean y (H - y) / (H / 2)^2, with U = 1.5 U_mean).
double inlet_profile(const FaceSpec& face, double y);

/// Turek and Hron's start-up of the inlet: (1 - cos(pi t / T)) / 2 for t < T, else 1 (T the
/// ramp time; T <= 0: 1 at once).
double inlet_ramp(double t, double T);

/// The outflow ghost of one boundary cell b by non-equilibrium extrapolation at a reference
/// density (Guo, Zheng and Shi 2002): from the 19 post-collision populations f*(b), whose
/// moments are the cell's own (the collision conserves rho and j, Eqs. 7-8),
///   ghost_q = f_eq_q(rho_out, u_b) + f*_q(b) - f_eq_q(rho_b, u_b)     (f_eq: Eq. 11),
/// for the populations that enter through the face (c_axis = inward); `ghost` gets those
/// (rounded once to T), the others are left alone.
/// One function for the ghost-fill pass and the kernel that writes x outflows on the fly
/// (stream_collide), so that both store the same bits. Both give it the cell's populations
/// as stored (`stored`, T): the ghost fill reads them back from the field, the kernel rounds
/// its registers with the store's own conversion first. The widening to double happens here,
/// out of line, and not in the kernel: GCC 12 at -march=x86-64-v3 drops the round trip
/// double -> float -> double for two of the 19 values when it vectorises it (fb[16], fb[17]
/// stayed unrounded), so a kernel-side (double)(float)x gave ghosts one float ulp off the
/// ghost fill's now and then (test_lbm_invariants: FusedStepMatchesGhostFillStepSingleStore).
template <class T>
void outflow_ghost(const T* stored, int axis, int inward, double rho_out, T* ghost);

/// The ghosts of the x faces of one row (InPlaceXFaces, fluid/collision/stream_collide.hpp) from its
/// post-collision populations as stored: f*_q(x) of the row at row[slot[q] + x], and the
/// ghost (q, x = -1 or nx) goes to row[slot[q] + x] too (slot: the layout's, e.g. q stride
/// for Canonical). The x faces of fill_ghosts, for the in-place kernel and its forced cells.
template <class T>
void in_place_x_ghosts(T* row, const std::ptrdiff_t* slot, int nx, int y, const InPlaceXFaces& xf);

/// The population arrays of a field as the ghost fills address them: A[q] itself for the
/// Canonical arrangement; for the Swapped one of the in-place propagation (PopulationLayout),
/// the slots that hold the same values, A[opp q] shifted by c_q (the other end of each pair
/// swap_layout turns). A fill through the Swapped slots writes and reads what it would on
/// the field turned Canonical, without turning it. Pointers only: no bounds beyond those
/// of the field's one allocation (19 arrays back to back, |c_q| < one stride).
template <class T>
class PopulationSlots {
 public:
  using value_type = T;
  PopulationSlots(BasicPopulationField<T>& f, PopulationLayout arrangement)
      : layout_(f.layout()), swapped_(arrangement == PopulationLayout::Swapped) {
    for (int q = 0; q < D3Q19::Q; ++q)
      q_[q] = swapped_ ? f.q(D3Q19::opp[q]) + layout_.offset(D3Q19::cx[q], D3Q19::cy[q], D3Q19::cz[q]) : f.q(q);
  }
  T* q(int i) const { return q_[i]; }
  /// The part x = lo .. hi of row (y, z) of population q that has a slot here, clipped in
  /// place; false where none has. Canonical: all of it. Swapped: the values (q, x) whose
  /// pair's other end x + c_q is in the extended grid (ghosts included); swap_layout leaves
  /// the others, ghosts on the outer ring that no cell pulls, and so do the fills (writing
  /// them would write into the neighbouring row, plane or array).
  bool clip(int q, int& lo, int& hi, int y, int z) const {
    if (!swapped_) return true;
    const int y2 = y + D3Q19::cy[q], z2 = z + D3Q19::cz[q];
    if (y2 < -1 || y2 > layout_.ny() || (!layout_.wraps_z() && (z2 < -1 || z2 > layout_.nz()))) return false;
    lo = std::max(lo, -1 - D3Q19::cx[q]);
    hi = std::min(hi, layout_.nx() - D3Q19::cx[q]);
    return lo <= hi;
  }
  bool has(int q, int x, int y, int z) const {
    int lo = x, hi = x;
    return clip(q, lo, hi, y, z);
  }

 private:
  GridLayout layout_;
  bool swapped_;
  T* q_[D3Q19::Q];
};

/// Fills the ghost layer of a field of post-collision populations so that a pull
/// (f_q(x) = f*_q(x - c_q)) at every interior cell realises the boundary conditions:
///  - Periodic: copy from the opposite face.
///  - Inlet: equilibrium (Eq. 11) at inlet_density and the inlet velocity.
///  - Outflow: zero-gradient velocity at a reference density (non-equilibrium
///    extrapolation, Guo, Zheng and Shi 2002): the ghost holds
///    f_eq(rho_out, u_b) + (f*_b - f_eq(rho_b, u_b)) of the last interior cell b. Velocity
///    and stress leave with zero gradient; the density (pressure) is pinned, so an open
///    channel neither gains nor loses mass without bound. A plain copy of all populations
///    pins nothing: with a velocity inlet the mass of the channel then drifts.
///  - Wall: half-way bounce-back, f_q(x) = f*_opp(x) + 6 E_q rho c_q.U_w (Eq. 14 with the
///    wall at half a cell outside the last interior layer).
///  - FreeSlip: specular reflection, f_q(x) = f*_mirror(q)(x - c_q + c_q,n n).
/// Copy-type faces are filled axis by axis (x, y, z), each over the ghosts of the axes
/// before it, so edges and corners come out right; an outflow's edge ghosts there
/// extrapolate from the interior cell the earlier ghost stands for (its periodic image, else
/// the nearest interior cell; fill_outflow in boundary.cpp), since the earlier fills write
/// only the populations entering the grid. Reflecting faces go last, free slip before walls,
/// so that a wall's bounce-back decides the edge it shares with free slip. Every pulled
/// ghost population is thus a function of the interior and the faces' constants, never of
/// what the ghosts held before (test_lbm_invariants: GhostFillDoesNotReadStaleValues).
/// Either store precision (T = double or float): values are computed
/// in double from the stored ones and rounded once when stored.
///
/// A block of a decomposed grid (DESIGN 8) has faces that are neither: a neighbour block's
/// edge plane goes into their ghosts. Those are the faces of a HaloExchange given to the
/// fills; the fills skip them and call the exchange between the copy-type faces and the
/// reflecting ones, the place of a periodic copy in the order above (a halo is a periodic
/// copy from another block), so that every ghost a pull reads gets the bits it has in the
/// undivided grid (test_mpi: MpiFluidMatchesSerialBitForBit).
class BoundaryConditions {
 public:
  BoundaryConditions() = default;
  /// `halo`: the faces a HaloExchange fills (their FaceSpec is not used; the pairing rule of
  /// check() does not apply to them). std::invalid_argument for halo faces on x (the blocks
  /// of fluid/mpi keep x whole), or on an axis before an outflow's (its edge ghosts would
  /// need the neighbour's whole cells).
  /// `y_origin`: the whole grid's row of this block's row 0 (FluidParams::y_origin).
  BoundaryConditions(const GridLayout& layout, const std::array<FaceSpec, kFaces>& faces,
                     const std::array<bool, kFaces>& halo = {}, int y_origin = 0);

  /// Empty string if the set is consistent, else a sentence naming the problem.
  static std::string check(const std::array<FaceSpec, kFaces>& faces,
                           const std::array<bool, kFaces>& halo = {});

  /// Every ghost of `f`, face by face as described above; the halo faces through `halo`
  /// (@pre given when the conditions have halo faces, and with those faces).
  template <class T>
  void fill_ghosts(BasicPopulationField<T>& f, HaloExchange* halo = nullptr) const;

  /// What a step needs, split (fluid_solver.cpp): the inlet ghosts are equilibria at a fixed
  /// density and velocity, the same at every step, so fill_static_ghosts writes them once
  /// per field; the outflows on x faces are written by the kernel as it stores each row's
  /// boundary cell (kernel_outflow()); fill_step_ghosts fills the rest, in the order of
  /// fill_ghosts. Together they leave every ghost that a pull reads with the bits that
  /// fill_ghosts gives (test_lbm_invariants: FusedStepMatchesGhostFillStep).
  template <class T>
  void fill_static_ghosts(BasicPopulationField<T>& f) const;
  /// @pre fill_static_ghosts(f) (or fill_ghosts(f)) was called once on this field, and the
  ///      kernel that wrote f's interior was given kernel_outflow()
  template <class T>
  void fill_step_ghosts(BasicPopulationField<T>& f, HaloExchange* halo = nullptr) const;
  KernelOutflow kernel_outflow() const;
  /// fill_ghosts without the x faces, for the in-place propagation, whose kernel writes the x
  /// faces' ghosts as it goes (in_place_x_faces): the y and z faces over the x ghosts there.
  template <class T>
  void fill_ghosts_but_x(BasicPopulationField<T>& f, HaloExchange* halo = nullptr) const;
  /// fill_ghosts (x_faces = true) or fill_ghosts_but_x (false) of an in-place state in the
  /// Swapped arrangement, through its slots (PopulationSlots): the bits the fill gives the
  /// state turned Canonical, turned back. @pre no halo faces (the exchange sends planes of
  /// the field as it is)
  template <class T>
  void fill_swapped_ghosts(BasicPopulationField<T>& f, bool x_faces) const;
  /// The x faces as the in-place kernel writes their ghosts (periodic, outflow, inlet: the
  /// arithmetic of fill_ghosts, outflow_ghost and the inlet equilibria of its fill); the other
  /// kinds (walls, free slip, halo) are Kind::Other, filled by fill_ghosts.
  InPlaceXFaces in_place_x_faces() const;
  /// A block's wall ghosts (Eq. 14) that the neighbour blocks' cells fill in the undivided
  /// grid: those of the boundary cells of the halo layers marked in `cells` (a halo face
  /// whose layer holds cells of the undivided grid: not the periodic image across the
  /// grid's wrap, whose cells are ghosts there), which lie in the block's own rows and
  /// planes (the populations that enter from the wall and leave towards the block). The
  /// block's own step never reads them (only the neighbours' cells pull them); a checkpoint
  /// that each block writes its share of then holds the undivided grid's values there
  /// (fluid/mpi/distributed_fluid.cpp). @pre the halo layers hold the neighbours' current
  /// cells (after a step's ghost fill)
  template <class T>
  void fill_wall_ghosts_of_halo_cells(BasicPopulationField<T>& f, const std::array<bool, kFaces>& cells) const;
  /// The x-outflow ghost of one boundary cell (x = 0 or nx - 1 next to an outflow face;
  /// nothing elsewhere), after the cell's populations were changed (a collision with an
  /// immersed-boundary force).
  template <class T>
  void fill_outflow_ghost(BasicPopulationField<T>& f, int x, int y, int z) const;

  /// Scales every inlet's velocity by `s` (the start-up ramp, inlet_ramp) from the next ghost
  /// fill on: the fills and the in-place kernel's x-inlet table use inlet_profile x s. The
  /// two-grid step's inlet ghosts are static (fill_static_ghosts): the solver fills them
  /// again (FluidSolver::set_inlet_scale).
  void set_inlet_scale(double s);
  double inlet_scale() const { return inlet_scale_; }

  const FaceSpec& face(int f) const { return faces_[f]; }
  /// Whether this face's fill reads all 19 populations of the cells it reads (an outflow's
  /// extrapolation, a halo exchange), not only those that cross the face.
  bool reads_every_population(int f) const { return halo_[f] || faces_[f].kind == FaceKind::Outflow; }
  /// Whether a neighbour block fills this face's ghosts.
  bool is_halo(int f) const { return halo_[f]; }
  bool has_halo() const;

 private:
  // Called inside a parallel region: their plane loops are worksharing loops without a
  // barrier (the loops of one face are independent); the caller puts one after each face.
  template <class T>
  void fill_copy_face(const PopulationSlots<T>& f, int face) const;
  template <class T>
  void fill_reflect_face(const PopulationSlots<T>& f, int face) const;
  /// The wall `face`'s ghosts of its boundary cells: the interior ones (cells_of = -1), or
  /// those of the halo layer of face `cells_of`, of the populations entering from the wall
  /// whose component along that face's axis is `c`.
  template <class T>
  void fill_wall(const PopulationSlots<T>& f, int face, int cells_of, int c) const;
  /// Which faces fill() fills: All (fill_ghosts), Step (fill_step_ghosts), AllButX
  /// (fill_ghosts_but_x).
  enum class Fill { All, Step, AllButX };
  /// The faces in order, the halo (if any) between two parallel regions.
  template <class T>
  void fill(BasicPopulationField<T>& f, HaloExchange* halo, Fill which,
            PopulationLayout arrangement = PopulationLayout::Canonical) const;
  /// Inside a parallel region: the copy-type faces from .. to - 1 that fill() fills, and the
  /// reflecting faces, a barrier after each face.
  template <class T>
  void fill_copy_faces(const PopulationSlots<T>& f, int from, int to, Fill which) const;
  template <class T>
  void fill_reflect_faces(const PopulationSlots<T>& f, Fill which) const;
  /// A copy-type face that this object fills in the fill `which`.
  bool fills_copy(int face, Fill which) const;

  GridLayout layout_;
  std::array<FaceSpec, kFaces> faces_{};
  std::array<bool, kFaces> halo_{};
  std::vector<double> inlet_x_ghosts_[2];  ///< x_min, x_max inlets: ny x 19 (in_place_x_faces)
  double inlet_scale_ = 1.0;               ///< set_inlet_scale
  int y_origin_ = 0;                       ///< the whole grid's row of row 0
  void fill_inlet_x_table();
};

}  // namespace cosim::fluid
