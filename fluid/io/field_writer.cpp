#include "fluid/io/field_writer.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "fluid/io/hdf5_handle.hpp"
#include "fluid/io/hdf5_quiet.hpp"
#include "common/hdf5/xdmf.hpp"
#include "common/run/atomic_file.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/run/provenance_h5.hpp"

namespace cosim::fluid {

namespace fs = std::filesystem;

FieldWriter::FieldWriter(std::string dir, double dx_um, double dt_us, std::string prefix,
                         int y_plane)
    : dir_(std::move(dir)), dx_um_(dx_um), dt_us_(dt_us), prefix_(std::move(prefix)),
      y_plane_(y_plane) {
  if (!(dx_um > 0.0) || !(dt_us > 0.0))
    throw std::invalid_argument("FieldWriter: dx_um and dt_us must be positive (got " + std::to_string(dx_um) +
                                " and " + std::to_string(dt_us) + ")");
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_))
    throw std::runtime_error("cannot create the field output directory " + dir_.string() +
                             (ec ? ": " + ec.message() : std::string(": a file of that name exists")));
}

std::string FieldWriter::snapshot_name(std::int64_t step) const {
  char buf[48];
  std::snprintf(buf, sizeof buf, "_%06lld.h5", static_cast<long long>(step));
  return prefix_ + buf;
}

void FieldPart::whole(const FluidSolver& solver, FieldPart& into) {
  solver.macroscopic(into.m);
  for (int a = 0; a < 3; ++a) into.periodic[std::size_t(a)] = solver.boundaries().face(2 * a).kind == FaceKind::Periodic;
  into.ghosts = 0;
  into.z0 = 0;
  into.nz_whole = solver.shape().nz;
  into.y_ghosts = 0;
  into.y0 = 0;
  into.ny_whole = solver.shape().ny;
  into.step = solver.step_count();
}

GridShape FieldWriter::written_shape() const {
  GridShape s = grid_;
  if (y_plane_ >= 0) s.ny = 1;
  return s;
}

bool FieldWriter::adopt(std::int64_t step) {
  // The shape the file itself holds (its rho [nz][ny][nx]): this writer has written nothing
  // yet after a restart. A file that does not open or lacks rho is not listed.
  GridShape shape{};
  {
    const H5Quiet quiet;
    const std::string name = snapshot_path(step).string();
    if (!std::filesystem::is_regular_file(name)) return false;
    const hid_t f = H5Fopen(name.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return false;
    hsize_t dims[3] = {0, 0, 0};
    bool ok = false;
    if (H5Lexists(f, "rho", H5P_DEFAULT) > 0) {
      const hid_t set = H5Dopen2(f, "rho", H5P_DEFAULT);
      const hid_t space = set >= 0 ? H5Dget_space(set) : -1;
      ok = space >= 0 && H5Sget_simple_extent_ndims(space) == 3 && H5Sget_simple_extent_dims(space, dims, nullptr) == 3;
      if (space >= 0) H5Sclose(space);
      if (set >= 0) H5Dclose(set);
    }
    H5Fclose(f);
    H5Eclear2(H5E_DEFAULT);
    if (!ok || dims[0] == 0 || dims[1] == 0 || dims[2] == 0) return false;
    shape.nz = int(dims[0]);
    shape.ny = int(dims[1]);
    shape.nx = int(dims[2]);
  }
  const auto same = [step](const Snapshot& s) { return s.step == step; };
  if (std::find_if(snapshots_.begin(), snapshots_.end(), same) == snapshots_.end())
    snapshots_.push_back({step, shape});
  return true;
}

void FieldWriter::write(const FluidSolver& solver) {
  FieldPart::whole(solver, whole_);
  write(whole_, nullptr);
}

void FieldWriter::write(const FieldPart& part, const protocol::WriteGroup* group) {
  const protocol::WriteGroup alone;
  const protocol::WriteGroup& g = group != nullptr ? *group : alone;
  const std::int64_t step = part.step;
  grid_ = GridShape{part.m.shape.nx, part.ny_whole, part.nz_whole};
  if (y_plane_ >= grid_.ny)
    throw std::invalid_argument("FieldWriter: plane y = " + std::to_string(y_plane_) +
                                " outside a grid of ny = " + std::to_string(grid_.ny));
  vorticity(part.m, part.periodic, part.y_ghosts, part.y0, part.ny_whole, part.ghosts, part.z0, part.nz_whole, wx_,
            wy_, wz_);

  // Whole or not at all (protocol::write_atomically): the part file, renamed when every
  // process has written its rows.
  const fs::path file = snapshot_path(step), part_file = protocol::part_path(file);
  std::string error;
  if (g.leads()) {
    try {
      create_hdf5(part_file, step);
    } catch (const std::exception& x) {
      error = x.what();
    }
  }
  if (error = g.first_error(error); error.empty()) {
    try {
      write_rows(part_file, part, g);
    } catch (const std::exception& x) {
      error = x.what();
    }
    error = g.first_error(error);
  }
  if (g.leads()) {
    try {
      if (error.empty()) protocol::rename_or_throw(part_file, file);
    } catch (const std::exception& x) {
      error = x.what();
    }
    if (!error.empty()) {
      std::error_code ec;
      fs::remove(part_file, ec);  // a full disk leaves no part file behind
    }
  }
  if (!(error = g.first_error(error)).empty()) throw std::runtime_error(error);

  const auto same = [step](const Snapshot& s) { return s.step == step; };
  const auto it = std::find_if(snapshots_.begin(), snapshots_.end(), same);
  if (it != snapshots_.end())
    it->shape = written_shape();
  else
    snapshots_.push_back({step, written_shape()});
  if (g.leads()) write_xdmf();
}

void FieldWriter::create_hdf5(const fs::path& file, std::int64_t step) const {
  const H5Quiet quiet;
  const std::string name = file.string();
  H5Id f = protocol::create_output_file(name, "cannot create the HDF5 file " + name);
  protocol::put_attribute(f.get(), "step", std::int64_t(step));
  protocol::put_attribute(f.get(), "time_us", double(step) * dt_us_);
  protocol::put_attribute(f.get(), "dx_um", dx_um_);
  protocol::put_attribute(f.get(), "dt_us", dt_us_);

  if (y_plane_ >= 0) {
    // Node j sits at (j + 1/2) dx in the sheets' frame (plate at y = 0), like the XDMF geometry.
    protocol::put_attribute(f.get(), "y_um", (y_plane_ + 0.5) * dx_um_);
    protocol::put_attribute(f.get(), "y_cell", std::int64_t(y_plane_));
    protocol::put_attribute(f.get(), "grid_ny", std::int64_t(grid_.ny));
  }
  // float64 datasets [nz][ny][nx] (rho) and [nz][ny][nx][3] (u, vorticity in physical units).
  const GridShape s = written_shape();
  const std::vector<hsize_t> scalar{hsize_t(s.nz), hsize_t(s.ny), hsize_t(s.nx)};
  const std::vector<hsize_t> vector{hsize_t(s.nz), hsize_t(s.ny), hsize_t(s.nx), 3};
  const std::array<std::pair<const char*, const char*>, 3> sets{{{"rho", "1 (rho / rho_0)"}, {"u", "m/s"}, {"vorticity", "1/us"}}};
  for (const auto& [set, units] : sets) {
    const H5Id d = protocol::reserve_dataset(f.get(), set, H5T_IEEE_F64LE, std::string(set) == "rho" ? scalar : vector,
                                             "cannot create " + name + ":/" + set);
    protocol::put_units(d.get(), set, units);
  }
  protocol::stamp_file(f.get());
  f.close("cannot close the HDF5 file " + name);
}

void FieldWriter::write_rows(const fs::path& file, const FieldPart& part, const protocol::WriteGroup& g) {
  const H5Quiet quiet;
  const std::string name = file.string();
  H5Id f = protocol::open_for_hyperslabs(name, g, "cannot open the HDF5 file " + name);
  // This part's cells in file order (x fastest): its rows of its planes, all of them or
  // the row y_plane (none where the part does not hold it).
  const MacroscopicFields& m = part.m;
  const bool holds_plane = y_plane_ >= part.y0 && y_plane_ < part.y0 + part.ny();
  const int ny = y_plane_ >= 0 ? (holds_plane ? 1 : 0) : part.ny();
  std::vector<std::size_t> cells;
  cells.reserve(std::size_t(m.shape.nx) * std::size_t(ny) * std::size_t(part.nz()));
  for (int z = part.ghosts; z < part.ghosts + part.nz(); ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < m.shape.nx; ++x)
        cells.push_back(m.index(x, part.y_ghosts + (y_plane_ >= 0 ? y_plane_ - part.y0 : y), z));
  const std::size_t n = cells.size();
  const hsize_t first = hsize_t(part.z0), rows = ny == 0 ? 0 : hsize_t(part.nz());
  const hsize_t first_y = y_plane_ >= 0 ? 0 : hsize_t(part.y0), count_y = hsize_t(ny);
  std::vector<double> rho(n);
  for (std::size_t i = 0; i < n; ++i) rho[i] = m.rho[cells[i]];
  protocol::write_box(f.get(), "rho", H5T_NATIVE_DOUBLE, first, rows, first_y, count_y, rho.data(), g, "cannot write " + name + ":/rho");

  // Vectors interleaved per cell, [nz][ny][nx][3], in physical units.
  vec_.resize(3 * n);
  const double u_scale = dx_um_ / dt_us_;  // um/us = m/s
  for (std::size_t i = 0; i < n; ++i) {
    vec_[3 * i] = u_scale * m.ux[cells[i]];
    vec_[3 * i + 1] = u_scale * m.uy[cells[i]];
    vec_[3 * i + 2] = u_scale * m.uz[cells[i]];
  }
  protocol::write_box(f.get(), "u", H5T_NATIVE_DOUBLE, first, rows, first_y, count_y, vec_.data(), g, "cannot write " + name + ":/u");
  const double w_scale = 1.0 / dt_us_;  // 1/us
  for (std::size_t i = 0; i < n; ++i) {
    vec_[3 * i] = w_scale * wx_[cells[i]];
    vec_[3 * i + 1] = w_scale * wy_[cells[i]];
    vec_[3 * i + 2] = w_scale * wz_[cells[i]];
  }
  protocol::write_box(f.get(), "vorticity", H5T_NATIVE_DOUBLE, first, rows, first_y, count_y, vec_.data(), g,
                       "cannot write " + name + ":/vorticity");
  f.close("cannot close the HDF5 file " + name);
}

void FieldWriter::write_xdmf() const {
  namespace xdmf = protocol::xdmf;
  std::vector<xdmf::Grid> grids;
  for (const Snapshot& snap : snapshots_) {
    const GridShape& s = snap.shape;
    const std::string file = snapshot_name(snap.step);
    const std::string dims = std::to_string(s.nz) + ' ' + std::to_string(s.ny) + ' ' + std::to_string(s.nx);
    xdmf::Grid g;
    g.name = "step_" + std::to_string(snap.step);
    g.time = double(snap.step) * dt_us_;
    g.topology = {"3DCoRectMesh", {{"Dimensions", dims}}, {}};
    // ORIGIN_DXDYDZ lists z, y, x (slowest first), like the topology's Dimensions. Node
    // (i, j, k) sits at (i, j + 1/2, k) dx, the frame of the sheets (sheets.xmf: the plate,
    // the half-way bounce-back wall at lattice y = -1/2, is y = 0; protocol/README.md
    // section 4; XdmfGeometryMatchesSheets).
    g.geometry = {"ORIGIN_DXDYDZ",
                  {xdmf::xml({0.0, ((y_plane_ >= 0 ? y_plane_ : 0) + 0.5) * dx_um_, 0.0}),
                   xdmf::xml({dx_um_, dx_um_, dx_um_})}};
    g.attributes = {{"rho", "Scalar", xdmf::hdf(file, "rho", "Float", 8, dims)},
                    {"u", "Vector", xdmf::hdf(file, "u", "Float", 8, dims + " 3")},
                    {"vorticity", "Vector", xdmf::hdf(file, "vorticity", "Float", 8, dims + " 3")}};
    grids.push_back(std::move(g));
  }
  xdmf::write_temporal_collection(xdmf_path(), prefix_, grids);
}

}  // namespace cosim::fluid
