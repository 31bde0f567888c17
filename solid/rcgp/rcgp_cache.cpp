#include "solid/rcgp/rcgp_cache.hpp"

#include <hdf5.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/hdf5/h5_writer.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "solid/rcgp/graphene_lattice.hpp"

namespace cosim::solid {

namespace {

namespace fs = std::filesystem;
using protocol::H5Id;
using protocol::H5Quiet;
using protocol::h5_check;

/// Bump when the layout of the file changes (a change of the construction's result bumps
/// the input hash instead).
constexpr std::int64_t kFormatVersion = 1;
/// Stages a file may hold (build_rcgp allows 1..16) and kernel ranges it may hold.
constexpr std::int64_t kMaxStages = 16;
constexpr std::int64_t kMaxRange = 16;

[[noreturn]] void bad(const std::string& what) { throw std::runtime_error(what); }

/// "/a" + "b" -> "/a/b"; "/" + "b" -> "/b".
std::string child(const std::string& where, const std::string& name) {
  return (where == "/" ? where : where + "/") + name;
}

std::string attr_name(const std::string& where, const char* name) {
  return std::string("attribute ") + name + " of " + where;
}

std::string shape_text(const std::vector<hsize_t>& dims) {
  std::string s = "(";
  for (std::size_t i = 0; i < dims.size(); ++i)
    s += (i == 0 ? "" : ", ") + std::to_string(dims[i]);
  return s + ")";
}

/// The model whose inputs a construction records (for its input hash).
ForceConstantModel model_of(const RcgpConstruction& c) {
  return ForceConstantModel(c.force_constants, GrapheneLattice(c.bond_length_m), c.atom_mass_kg);
}

template <class M>
std::vector<double> row_major(const M& m) {
  std::vector<double> v;
  v.reserve(static_cast<std::size_t>(m.size()));
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) v.push_back(m(r, c));
  return v;
}

template <class M>
void from_row_major(const std::vector<double>& v, M& m) {
  std::size_t i = 0;
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) m(r, c) = v[i++];
}

// ---- writing ------------------------------------------------------------------------------

void put_double(hid_t obj, const std::string& where, const char* name, double value) {
  protocol::put_attribute(obj, name, value, "cannot write the " + attr_name(where, name));
}

void put_int(hid_t obj, const std::string& where, const char* name, std::int64_t value) {
  protocol::put_attribute(obj, name, value, "cannot write the " + attr_name(where, name));
}

void put_string(hid_t obj, const std::string& where, const char* name, const std::string& value) {
  // With its terminating NUL (the format of the files written so far).
  protocol::put_attribute(obj, name, value, protocol::StringSize::with_nul,
                          "cannot write the " + attr_name(where, name));
}

void put_array(hid_t loc, const std::string& where, const char* name,
               const std::vector<hsize_t>& dims, const std::vector<double>& data,
               const char* units) {
  const std::string path = child(where, name);
  const H5Id dset = protocol::write_dataset(loc, name, std::span<const double>(data), dims,
                                            "cannot write the dataset " + path);
  put_string(dset.get(), path, "units", units);
}

H5Id make_group(hid_t parent, const std::string& path, const char* name) {
  return H5Id(H5Gcreate2(parent, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
              "cannot create the group " + path);
}

void put_kernel(hid_t parent, const std::string& where, const char* name, const CgKernel& k) {
  const std::string path = child(where, name);
  const H5Id g = make_group(parent, path, name);
  put_double(g.get(), path, "ax_m", k.ax_m);
  put_double(g.get(), path, "ay_m", k.ay_m);
  put_int(g.get(), path, "range", k.range);
  std::vector<double> ip;
  ip.reserve(4 * k.in_plane.size());
  for (const Eigen::Matrix2d& b : k.in_plane)
    for (const double v : row_major(b)) ip.push_back(v);
  put_array(g.get(), path, "in_plane", {k.in_plane.size(), 2, 2}, ip, "N/m");
  put_array(g.get(), path, "flexural", {k.flexural.size()}, k.flexural, "N/m");
}

void put_moments(hid_t parent, const std::string& where, const char* name, const KernelMoments& m) {
  const std::string path = child(where, name);
  const H5Id g = make_group(parent, path, name);
  put_array(g.get(), path, "in_plane_sum", {2, 2}, row_major(m.in_plane_sum), "N/m");
  put_array(g.get(), path, "in_plane_second", {4, 3}, row_major(m.in_plane_second), "N m");
  put_double(g.get(), path, "flexural_sum", m.flexural_sum);
  put_array(g.get(), path, "flexural_second", {3}, row_major(m.flexural_second), "N m");
  put_array(g.get(), path, "flexural_fourth", {5}, row_major(m.flexural_fourth), "N m^3");
}

void put_constants(hid_t parent, const std::string& where, const char* name, const SheetConstants& c) {
  const std::string path = child(where, name);
  const H5Id g = make_group(parent, path, name);
  put_double(g.get(), path, "c11_N_m", c.c11_N_m);
  put_double(g.get(), path, "c22_N_m", c.c22_N_m);
  put_double(g.get(), path, "c12_N_m", c.c12_N_m);
  put_double(g.get(), path, "c66_N_m", c.c66_N_m);
  put_double(g.get(), path, "d11_J", c.d11_J);
  put_double(g.get(), path, "d22_J", c.d22_J);
  put_double(g.get(), path, "d_mixed_J", c.d_mixed_J);
}

void put_spectrum(hid_t parent, const std::string& where, const char* name, const KernelSpectrum& s) {
  const std::string path = child(where, name);
  const H5Id g = make_group(parent, path, name);
  put_double(g.get(), path, "in_plane_min_rel", s.in_plane_min_rel);
  put_double(g.get(), path, "flexural_min_rel", s.flexural_min_rel);
  put_double(g.get(), path, "in_plane_max_N_m", s.in_plane_max_N_m);
  put_double(g.get(), path, "flexural_max_N_m", s.flexural_max_N_m);
}

std::string stage_name(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%02zu", i + 1);
  return buf;
}

void write_file(const RcgpConstruction& c, const std::string& file, const std::string& hash) {
  H5Id f(H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
         "cannot create the HDF5 file " + file);
  const hid_t root = f.get();
  put_int(root, "/", "format_version", kFormatVersion);
  put_string(root, "/", "input_hash", hash);
  put_double(root, "/", "bond_length_m", c.bond_length_m);
  put_double(root, "/", "atom_mass_kg", c.atom_mass_kg);
  put_double(root, "/", "stage1_mass_identity_defect", c.stage1_mass_identity_defect);
  {
    const H5Id g = make_group(root, "/options", "options");
    const RcgpOptions& o = c.options;
    put_int(g.get(), "/options", "stages", o.stages);
    put_string(g.get(), "/options", "flexural_scaling",
               o.flexural_scaling == FlexuralScaling::Paper ? "paper" : "physical");
    put_int(g.get(), "/options", "truncation_range", o.truncation_range);
    put_int(g.get(), "/options", "moment_matching", o.moment_matching ? 1 : 0);
    put_double(g.get(), "/options", "bending_poisson", o.bending_poisson);
    put_string(g.get(), "/options", "cache_dir", o.cache_dir);
  }
  {
    std::vector<double> fc;
    for (const ShellForceConstants& s : c.force_constants.shells) {
      fc.push_back(s.radial_N_m);
      fc.push_back(s.tangential_in_N_m);
      fc.push_back(s.tangential_out_N_m);
    }
    put_array(root, "/", "force_constants", {c.force_constants.shells.size(), 3}, fc, "N/m");
  }
  {
    const H5Id g = make_group(root, "/atomistic", "atomistic");
    put_double(g.get(), "/atomistic", "c11_N_m", c.atomistic.c11_N_m);
    put_double(g.get(), "/atomistic", "c12_N_m", c.atomistic.c12_N_m);
    put_double(g.get(), "/atomistic", "c66_N_m", c.atomistic.c66_N_m);
    put_double(g.get(), "/atomistic", "youngs_modulus_N_m", c.atomistic.youngs_modulus_N_m);
    put_double(g.get(), "/atomistic", "poisson_ratio", c.atomistic.poisson_ratio);
    put_double(g.get(), "/atomistic", "kappa_J", c.atomistic_kappa_J);
  }
  put_array(root, "/", "stage1_consistent_mass_kg", {c.stage1_consistent_mass_kg.size()},
            c.stage1_consistent_mass_kg, "kg");
  const H5Id stages = make_group(root, "/stages", "stages");
  put_int(stages.get(), "/stages", "count", static_cast<std::int64_t>(c.stages.size()));
  for (std::size_t i = 0; i < c.stages.size(); ++i) {
    const RcgpStage& st = c.stages[i];
    const std::string name = stage_name(i);
    const std::string path = child("/stages", name);
    const H5Id g = make_group(stages.get(), path, name.c_str());
    put_int(g.get(), path, "stage", st.stage);
    put_double(g.get(), path, "lumped_mass_kg", st.lumped_mass_kg);
    put_double(g.get(), path, "atoms_per_cgp", st.atoms_per_cgp);
    put_double(g.get(), path, "translation_invariance_defect", st.translation_invariance_defect);
    put_double(g.get(), path, "stable_time_step_s", st.stable_time_step_s);
    put_kernel(g.get(), path, "projected", st.projected);
    put_kernel(g.get(), path, "kernel", st.kernel);
    put_moments(g.get(), path, "target", st.target);
    put_constants(g.get(), path, "constants", st.constants);
    put_spectrum(g.get(), path, "spectrum", st.spectrum);
  }
  f.close("cannot close the HDF5 file " + file);
}

// ---- reading ------------------------------------------------------------------------------

/// Opens a scalar attribute of type class `cls`; `what` receives the message prefix.
H5Id open_attr(hid_t obj, const std::string& where, const char* name, H5T_class_t cls,
               std::string& what) {
  what = "cannot read the " + attr_name(where, name);
  H5Id attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, what);
  const H5Id space(H5Aget_space(attr.get()), H5Sclose, what);
  if (H5Sget_simple_extent_npoints(space.get()) != 1) bad(what + ": not a scalar");
  const H5Id type(H5Aget_type(attr.get()), H5Tclose, what);
  if (H5Tget_class(type.get()) != cls) bad(what + ": of the wrong type");
  return attr;
}

double get_double(hid_t obj, const std::string& where, const char* name) {
  std::string what;
  const H5Id attr = open_attr(obj, where, name, H5T_FLOAT, what);
  double v = 0.0;
  h5_check(H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &v), what);
  return v;
}

std::int64_t get_int(hid_t obj, const std::string& where, const char* name, std::int64_t lo,
                     std::int64_t hi) {
  std::string what;
  const H5Id attr = open_attr(obj, where, name, H5T_INTEGER, what);
  std::int64_t v = 0;
  h5_check(H5Aread(attr.get(), H5T_NATIVE_INT64, &v), what);
  if (v < lo || v > hi)
    bad("the " + attr_name(where, name) + " is " + std::to_string(v) + ", allowed " +
        std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

int get_small_int(hid_t obj, const std::string& where, const char* name, int lo, int hi) {
  return static_cast<int>(get_int(obj, where, name, lo, hi));
}

std::string get_string(hid_t obj, const std::string& where, const char* name) {
  std::string what;
  const H5Id attr = open_attr(obj, where, name, H5T_STRING, what);
  const H5Id type(H5Aget_type(attr.get()), H5Tclose, what);
  if (H5Tis_variable_str(type.get()) != 0) bad(what + ": not a fixed-length string");
  const std::size_t size = H5Tget_size(type.get());
  if (size == 0 || size > (1u << 20)) bad(what + ": a string of " + std::to_string(size) + " bytes");
  std::string buf(size, '\0');
  h5_check(H5Aread(attr.get(), type.get(), buf.data()), what);
  const std::size_t end = buf.find('\0');
  if (end != std::string::npos) buf.resize(end);
  return buf;
}

std::vector<double> get_array(hid_t loc, const std::string& where, const char* name,
                              const std::vector<hsize_t>& expected) {
  const std::string path = child(where, name);
  const std::string what = "cannot read the dataset " + path;
  const H5Id dset(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose, what);
  const H5Id type(H5Dget_type(dset.get()), H5Tclose, what);
  if (H5Tget_class(type.get()) != H5T_FLOAT) bad(what + ": not floating point");
  const H5Id space(H5Dget_space(dset.get()), H5Sclose, what);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) protocol::h5_fail(what);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0) h5_check(H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr), what);
  if (dims != expected)
    bad("the dataset " + path + " has the shape " + shape_text(dims) + ", expected " +
        shape_text(expected));
  std::size_t n = 1;
  for (const hsize_t d : dims) n *= d;
  std::vector<double> v(n);
  if (n > 0)
    h5_check(H5Dread(dset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), what);
  return v;
}

H5Id open_group(hid_t parent, const std::string& path, const char* name) {
  return H5Id(H5Gopen2(parent, name, H5P_DEFAULT), H5Gclose, "cannot open the group " + path);
}

CgKernel get_kernel(hid_t parent, const std::string& where, const char* name) {
  const std::string path = child(where, name);
  const H5Id g = open_group(parent, path, name);
  CgKernel k;
  k.ax_m = get_double(g.get(), path, "ax_m");
  k.ay_m = get_double(g.get(), path, "ay_m");
  k.range = get_small_int(g.get(), path, "range", 0, static_cast<int>(kMaxRange));
  const auto entries = static_cast<hsize_t>(k.width()) * static_cast<hsize_t>(k.width());
  const std::vector<double> ip = get_array(g.get(), path, "in_plane", {entries, 2, 2});
  k.in_plane.resize(static_cast<std::size_t>(entries));
  for (std::size_t i = 0; i < k.in_plane.size(); ++i)
    from_row_major(std::vector<double>(ip.begin() + static_cast<std::ptrdiff_t>(4 * i),
                                       ip.begin() + static_cast<std::ptrdiff_t>(4 * i + 4)),
                   k.in_plane[i]);
  k.flexural = get_array(g.get(), path, "flexural", {entries});
  return k;
}

KernelMoments get_moments(hid_t parent, const std::string& where, const char* name) {
  const std::string path = child(where, name);
  const H5Id g = open_group(parent, path, name);
  KernelMoments m;
  from_row_major(get_array(g.get(), path, "in_plane_sum", {2, 2}), m.in_plane_sum);
  from_row_major(get_array(g.get(), path, "in_plane_second", {4, 3}), m.in_plane_second);
  m.flexural_sum = get_double(g.get(), path, "flexural_sum");
  from_row_major(get_array(g.get(), path, "flexural_second", {3}), m.flexural_second);
  from_row_major(get_array(g.get(), path, "flexural_fourth", {5}), m.flexural_fourth);
  return m;
}

SheetConstants get_constants(hid_t parent, const std::string& where, const char* name) {
  const std::string path = child(where, name);
  const H5Id g = open_group(parent, path, name);
  SheetConstants c;
  c.c11_N_m = get_double(g.get(), path, "c11_N_m");
  c.c22_N_m = get_double(g.get(), path, "c22_N_m");
  c.c12_N_m = get_double(g.get(), path, "c12_N_m");
  c.c66_N_m = get_double(g.get(), path, "c66_N_m");
  c.d11_J = get_double(g.get(), path, "d11_J");
  c.d22_J = get_double(g.get(), path, "d22_J");
  c.d_mixed_J = get_double(g.get(), path, "d_mixed_J");
  return c;
}

KernelSpectrum get_spectrum(hid_t parent, const std::string& where, const char* name) {
  const std::string path = child(where, name);
  const H5Id g = open_group(parent, path, name);
  KernelSpectrum s;
  s.in_plane_min_rel = get_double(g.get(), path, "in_plane_min_rel");
  s.flexural_min_rel = get_double(g.get(), path, "flexural_min_rel");
  s.in_plane_max_N_m = get_double(g.get(), path, "in_plane_max_N_m");
  s.flexural_max_N_m = get_double(g.get(), path, "flexural_max_N_m");
  return s;
}

/// Reads a file of save_rcgp(); throws std::runtime_error with what is wrong (the caller
/// names the file). `hash` receives the stored input hash.
RcgpConstruction read_file(const std::string& file, std::string& hash) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) bad(ec ? ec.message() : "no such file");
  const H5Id f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose,
               "not a readable HDF5 file");
  const hid_t root = f.get();
  const std::int64_t version = get_int(root, "/", "format_version", 0, INT64_MAX);
  if (version != kFormatVersion)
    bad("format version " + std::to_string(version) + ", expected " + std::to_string(kFormatVersion));
  hash = get_string(root, "/", "input_hash");

  RcgpConstruction c;
  c.bond_length_m = get_double(root, "/", "bond_length_m");
  c.atom_mass_kg = get_double(root, "/", "atom_mass_kg");
  c.stage1_mass_identity_defect = get_double(root, "/", "stage1_mass_identity_defect");
  {
    const H5Id g = open_group(root, "/options", "options");
    RcgpOptions& o = c.options;
    o.stages = get_small_int(g.get(), "/options", "stages", 1, static_cast<int>(kMaxStages));
    const std::string scaling = get_string(g.get(), "/options", "flexural_scaling");
    if (scaling == "paper")
      o.flexural_scaling = FlexuralScaling::Paper;
    else if (scaling == "physical")
      o.flexural_scaling = FlexuralScaling::Physical;
    else
      bad("the " + attr_name("/options", "flexural_scaling") + " is \"" + scaling +
          "\", allowed \"paper\" or \"physical\"");
    o.truncation_range =
        get_small_int(g.get(), "/options", "truncation_range", 0, static_cast<int>(kMaxRange));
    o.moment_matching = get_int(g.get(), "/options", "moment_matching", 0, 1) == 1;
    o.bending_poisson = get_double(g.get(), "/options", "bending_poisson");
    o.cache_dir = get_string(g.get(), "/options", "cache_dir");
  }
  {
    auto& shells = c.force_constants.shells;
    const std::vector<double> fc = get_array(root, "/", "force_constants", {shells.size(), 3});
    for (std::size_t s = 0; s < shells.size(); ++s) {
      shells[s].radial_N_m = fc[3 * s];
      shells[s].tangential_in_N_m = fc[3 * s + 1];
      shells[s].tangential_out_N_m = fc[3 * s + 2];
    }
  }
  {
    const H5Id g = open_group(root, "/atomistic", "atomistic");
    c.atomistic.c11_N_m = get_double(g.get(), "/atomistic", "c11_N_m");
    c.atomistic.c12_N_m = get_double(g.get(), "/atomistic", "c12_N_m");
    c.atomistic.c66_N_m = get_double(g.get(), "/atomistic", "c66_N_m");
    c.atomistic.youngs_modulus_N_m = get_double(g.get(), "/atomistic", "youngs_modulus_N_m");
    c.atomistic.poisson_ratio = get_double(g.get(), "/atomistic", "poisson_ratio");
    c.atomistic_kappa_J = get_double(g.get(), "/atomistic", "kappa_J");
  }
  const H5Id stages = open_group(root, "/stages", "stages");
  const std::int64_t count = get_int(stages.get(), "/stages", "count", 1, kMaxStages);
  if (count != c.options.stages)
    bad("/stages holds " + std::to_string(count) + " stages, /options says " +
        std::to_string(c.options.stages));
  for (std::size_t i = 0; i < static_cast<std::size_t>(count); ++i) {
    const std::string name = stage_name(i);
    const std::string path = child("/stages", name);
    const H5Id g = open_group(stages.get(), path, name.c_str());
    RcgpStage st;
    st.stage = get_small_int(g.get(), path, "stage", static_cast<int>(i + 1), static_cast<int>(i + 1));
    st.lumped_mass_kg = get_double(g.get(), path, "lumped_mass_kg");
    st.atoms_per_cgp = get_double(g.get(), path, "atoms_per_cgp");
    st.translation_invariance_defect = get_double(g.get(), path, "translation_invariance_defect");
    st.stable_time_step_s = get_double(g.get(), path, "stable_time_step_s");
    st.projected = get_kernel(g.get(), path, "projected");
    st.kernel = get_kernel(g.get(), path, "kernel");
    st.target = get_moments(g.get(), path, "target");
    st.constants = get_constants(g.get(), path, "constants");
    st.spectrum = get_spectrum(g.get(), path, "spectrum");
    c.stages.push_back(std::move(st));
  }
  const auto mass_entries = static_cast<hsize_t>(c.stages.front().kernel.in_plane.size());
  c.stage1_consistent_mass_kg = get_array(root, "/", "stage1_consistent_mass_kg", {mass_entries});
  return c;
}

std::string random_suffix() {
  std::random_device rd;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%08x%08x", static_cast<unsigned>(rd()), static_cast<unsigned>(rd()));
  return buf;
}

}  // namespace

std::string rcgp_cache_file(const RcgpOptions& options, const ForceConstantModel& atoms) {
  if (options.cache_dir.empty()) return {};
  return (fs::path(options.cache_dir) / ("rcgp-" + rcgp_input_hash(options, atoms) + ".h5")).string();
}

void save_rcgp(const RcgpConstruction& construction, const std::string& path) {
  const H5Quiet quiet;
  const std::string fail = "cannot write the RCGP construction to " + path + ": ";
  const fs::path final_path(path);
  fs::path part = final_path;
  part += ".part-" + random_suffix();
  try {
    write_file(construction, part.string(), rcgp_input_hash(construction.options, model_of(construction)));
  } catch (const std::exception& e) {
    std::error_code ignored;
    fs::remove(part, ignored);
    throw std::runtime_error(fail + e.what());
  }
  std::error_code ec;
  fs::rename(part, final_path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(part, ignored);
    throw std::runtime_error(fail + "cannot rename " + part.string() + " to it: " + ec.message());
  }
}

RcgpConstruction load_rcgp(const std::string& path) {
  const H5Quiet quiet;
  try {
    std::string hash;
    return read_file(path, hash);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot load the RCGP construction from " + path + ": " + e.what());
  }
}

RcgpConstruction load_or_build_rcgp(const RcgpOptions& options, const ForceConstantModel& atoms,
                                    std::string* how) {
  using Clock = std::chrono::steady_clock;
  const auto built_in = [](Clock::time_point t0) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "built in %.2f s",
                  std::chrono::duration<double>(Clock::now() - t0).count());
    return std::string(buf);
  };
  if (options.cache_dir.empty()) {
    const Clock::time_point t0 = Clock::now();
    RcgpConstruction c = build_rcgp(options, atoms);
    if (how != nullptr) *how = built_in(t0) + " (no cache_dir)";
    return c;
  }

  const fs::path dir(options.cache_dir);
  std::error_code ec;
  fs::create_directories(dir, ec);
  std::error_code dir_ec;
  if (ec || !fs::is_directory(dir, dir_ec))
    throw std::runtime_error("cannot create the RCGP cache directory " + dir.string() + ": " +
                             (ec ? ec.message() : "a file of that name exists"));

  const std::string key = rcgp_input_hash(options, atoms);
  const std::string file = rcgp_cache_file(options, atoms);
  std::string problem;  // why an existing file was not used
  std::error_code exists_ec;
  if (fs::exists(file, exists_ec)) {
    try {
      const H5Quiet quiet;
      std::string stored;
      RcgpConstruction c = read_file(file, stored);
      if (stored != key) {
        problem = "it holds the input hash " + stored + ", not " + key;
      } else if (rcgp_input_hash(c.options, model_of(c)) != key) {
        problem = "its contents do not match its input hash " + key;
      } else {
        // Same inputs; the options that the construction does not depend on (bending_poisson,
        // cache_dir) are the caller's, as build_rcgp() would return them.
        c.options = options;
        if (how != nullptr) *how = "loaded from " + file;
        return c;
      }
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }

  const Clock::time_point t0 = Clock::now();
  RcgpConstruction c = build_rcgp(options, atoms);
  const std::string built = built_in(t0);
  save_rcgp(c, file);
  if (how != nullptr) {
    *how = built + ", cached in " + file;
    if (!problem.empty()) *how += " (replaced an unusable cache file: " + problem + ")";
  }
  return c;
}

}  // namespace cosim::solid
