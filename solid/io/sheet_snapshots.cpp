#include "solid/io/sheet_snapshots.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "common/hdf5/xdmf.hpp"
#include "common/run/atomic_file.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "protocol/units.hpp"
#include "solid/models/elastic_sheet/elastic_sheet_model.hpp"
#include "solid/model/sheet_spec.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/run/provenance_h5.hpp"

namespace cosim::solid {

namespace {

namespace fs = std::filesystem;
using protocol::H5Id;
using protocol::PhysicalConstants;
using protocol::UnitConverter;

constexpr double kMicrometre = 1e-6;

constexpr const char* kFrame =
    "the solid's: x stream-wise, y up from the plate surface y = 0, z span-wise, "
    "micrometres; the fluid's lattice cell (i, j, k) (fields.xmf) is at (i, j + 1/2, k) dx";
constexpr const char* kStrainDefinition =
    "area strain eps_l = (|dA_l| - |dA_l0|) / |dA_l0|, dA_l = t_a x t_b from central "
    "differences along the width and height (one-sided at edges), 0 for the flat sheet "
    "(the paper's section 3.2 and Fig. 11)";

}  // namespace

bool sheet_snapshot_due(std::int64_t step, std::int64_t last, std::int64_t every) {
  return every > 0 && (step % every == 0 || step == last);
}

SheetSnapshotWriter::SheetSnapshotWriter(fs::path dir, const SolidConfig& config)
    : dir_(std::move(dir)), config_(config) {
  if (config_.sheets.empty())
    throw std::invalid_argument("SheetSnapshotWriter: a configuration without sheets");
  n_ = total_cgps(config_);
  reference_bohr_.resize(3, n_);
  sheet_of_.reserve(static_cast<std::size_t>(n_));
  for (std::size_t s = 0; s < config_.sheets.size(); ++s) {
    const SheetSpec& sh = config_.sheets[s];
    const Eigen::Index first = first_cgp(config_, s);
    reference_bohr_.middleCols(first, sh.num_cgps()) = flat_sheet_positions(sh);  // checks sh
    sheet_of_.insert(sheet_of_.end(), static_cast<std::size_t>(sh.num_cgps()),
                     static_cast<std::int32_t>(s));
    grid_.push_back(sh.nx_cg);
    grid_.push_back(sh.ny_cg);
    for (int j = 0; j + 1 < sh.ny_cg; ++j)
      for (int i = 0; i + 1 < sh.nx_cg; ++i)
        for (const Eigen::Index l :
             {sh.index(i, j), sh.index(i + 1, j), sh.index(i + 1, j + 1), sh.index(i, j + 1)})
          quads_.push_back(static_cast<std::int64_t>(first + l));
  }
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_))
    throw std::runtime_error("cannot create the output directory " + dir_.string() +
                             (ec ? ": " + ec.message() : std::string(": a file of that name exists")));
}

std::string SheetSnapshotWriter::snapshot_name(std::int64_t step) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "sheets_%06lld.h5", static_cast<long long>(step));
  return buf;
}

bool SheetSnapshotWriter::adopt(std::int64_t step, double time_s) {
  if (!fs::is_regular_file(snapshot_path(step))) return false;
  const auto same = [step](const Snapshot& s) { return s.step == step; };
  if (std::find_if(snapshots_.begin(), snapshots_.end(), same) == snapshots_.end())
    snapshots_.push_back({step, time_s / kMicrometre});
  return true;
}

void SheetSnapshotWriter::write(std::int64_t step, double time_s, const SolidModel& model) {
  if (model.num_cgps() != n_)
    throw std::invalid_argument("SheetSnapshotWriter: a model of " +
                                std::to_string(model.num_cgps()) + " CGPs, the sheets have " +
                                std::to_string(n_));
  protocol::write_atomically(snapshot_path(step), [&](const fs::path& part) { write_hdf5(part, step, time_s, model); });

  const double time_us = time_s / kMicrometre;
  const auto it = std::find_if(snapshots_.begin(), snapshots_.end(),
                               [step](const Snapshot& s) { return s.step == step; });
  if (it != snapshots_.end())
    it->time_us = time_us;
  else
    snapshots_.push_back({step, time_us});
  write_xdmf();
}

void SheetSnapshotWriter::write_hdf5(const fs::path& file, std::int64_t step, double time_s,
                                     const SolidModel& model) {
  const Eigen::Matrix3Xd& x = model.positions();
  const double um_per_bohr = PhysicalConstants::bohr_m / kMicrometre;
  // Column-major 3 x n is row-major n x 3.
  const Eigen::Matrix3Xd position_um = x * um_per_bohr;
  const Eigen::Matrix3Xd displacement_um = (x - reference_bohr_) * um_per_bohr;
  const Eigen::Matrix3Xd velocity_m_s = model.velocities() * UnitConverter::velocity_au_m_s();
  Eigen::VectorXd strain = model.observables().area_strain;
  if (strain.size() != n_) {  // a model that does not compute it
    strain.resize(n_);
    for (std::size_t s = 0; s < config_.sheets.size(); ++s) {
      const SheetSpec& sh = config_.sheets[s];
      const Eigen::Index first = first_cgp(config_, s);
      strain.segment(first, sh.num_cgps()) =
          area_strain(sh, x.middleCols(first, sh.num_cgps()),
                      reference_bohr_.middleCols(first, sh.num_cgps()));
    }
  }

  const protocol::H5Quiet quiet;
  const std::string name = file.string();
  H5Id f = protocol::create_output_file(name, "cannot create " + name);
  const hid_t h = f.get();
  const hsize_t n = static_cast<hsize_t>(n_), q = quads_.size() / 4, ns = grid_.size() / 2;
  try {
    protocol::write_dataset(h, "position_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3}, position_um.data());
    protocol::write_dataset(h, "displacement_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3},
                  displacement_um.data());
    protocol::write_dataset(h, "velocity_m_s", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3},
                  velocity_m_s.data());
    protocol::write_dataset(h, "area_strain", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, strain.data());
    protocol::write_dataset(h, "sheet", H5T_STD_I32LE, H5T_NATIVE_INT32, {n}, sheet_of_.data());
    protocol::write_dataset(h, "quads", H5T_STD_I64LE, H5T_NATIVE_INT64, {q, 4}, quads_.data());
    protocol::write_dataset(h, "sheet_grid", H5T_STD_I32LE, H5T_NATIVE_INT32, {ns, 2}, grid_.data());
    protocol::put_attribute(h, "step", step);
    protocol::put_attribute(h, "time_s", time_s);
    protocol::put_attribute(h, "time_us", time_s / kMicrometre);
    protocol::put_attribute(h, "frame", kFrame);
    protocol::put_attribute(h, "area_strain", kStrainDefinition);
    protocol::stamp_file(h);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(name + ": " + e.what());
  }
  f.close("cannot close " + name);
}

void SheetSnapshotWriter::write_xdmf() const {
  namespace xdmf = protocol::xdmf;
  const std::size_t n = static_cast<std::size_t>(n_), q = quads_.size() / 4;
  const std::string n1 = std::to_string(n), n3 = n1 + " 3";
  std::vector<xdmf::Grid> grids;
  for (const Snapshot& snap : snapshots_) {
    const std::string file = snapshot_name(snap.step);
    xdmf::Grid g;
    g.name = "step_" + std::to_string(snap.step);
    g.time = snap.time_us;
    g.topology = {"Quadrilateral",
                  {{"NumberOfElements", std::to_string(q)}},
                  {xdmf::hdf(file, "quads", "Int", 8, std::to_string(q) + " 4")}};
    g.geometry = {"XYZ", {xdmf::hdf(file, "position_um", "Float", 8, n3)}};
    g.attributes = {{"area_strain", "Scalar", xdmf::hdf(file, "area_strain", "Float", 8, n1)},
                    {"displacement_um", "Vector", xdmf::hdf(file, "displacement_um", "Float", 8, n3)},
                    {"velocity_m_s", "Vector", xdmf::hdf(file, "velocity_m_s", "Float", 8, n3)},
                    {"sheet", "Scalar", xdmf::hdf(file, "sheet", "Int", 4, n1)}};
    grids.push_back(std::move(g));
  }
  xdmf::write_temporal_collection(xdmf_path(), "sheets", grids);
}

}  // namespace cosim::solid
