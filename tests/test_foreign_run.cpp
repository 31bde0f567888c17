// A foreign run on the same channels (protocol/README.md sections 6-8): a second publisher
// (tests/foreign_publisher.cpp) sends messages of every type with another run token while
// the coupled scene runs through launch/run-coupled.sh (--extra: inside the run's private
// network namespace). Both servers count them ("foreign N" in their final counters line),
// never apply them, never answer them: the run completes and its results (every dataset of
// solid.h5 and monitor.h5) are bit for bit those of a clean run.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kSource = COSIM_SOURCE_DIR;
const std::string kPublisher = FOREIGN_PUBLISHER_EXE;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cosim_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

int run_launcher(const fs::path& scene, const fs::path& output, const std::string& extra = "") {
  fs::create_directories(output);
  const std::string cmd = "bash " + quoted((kSource / "launch" / "run-coupled.sh").string()) + " " +
                          quoted(scene.string()) + " --output " + quoted(output.string()) +
                          " --no-build --quiet" + (extra.empty() ? "" : " --extra " + quoted(extra)) +
                          " >" + quoted((output / "launcher.log").string()) + " 2>&1";
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

std::string logs(const fs::path& out) {
  std::string s;
  for (const char* f : {"launcher.log", "fluid.log", "solid.log", "extra.log"})
    s += std::string("--- ") + f + "\n" + slurp(out / f);
  return s;
}

/// The foreign count of the last counters line ("... foreign N, duplicates ...") of a log;
/// -1 if there is none.
long long foreign_count(const std::string& log) {
  static const std::regex re(R"(foreign ([0-9]+), duplicates)");
  long long n = -1;
  for (std::sregex_iterator it(log.begin(), log.end(), re), end; it != end; ++it)
    n = std::stoll((*it)[1].str());
  return n;
}

/// One dataset read back raw: its shape, its file type's class and size, its bytes (in the
/// file's own type, so the comparison is bit for bit), and its values as doubles.
struct Dataset {
  std::vector<hsize_t> dims;
  H5T_class_t cls = H5T_NO_CLASS;
  std::size_t type_size = 0;
  std::vector<unsigned char> bytes;
  std::vector<double> values;
};

/// Every dataset in the root group of an HDF5 file, by name; empty if it cannot be opened.
std::map<std::string, Dataset> read_datasets(const fs::path& file) {
  std::map<std::string, Dataset> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  std::vector<std::string> names;
  H5G_info_t group{};
  if (H5Gget_info(f, &group) >= 0)
    for (hsize_t k = 0; k < group.nlinks; ++k) {
      const ssize_t len = H5Lget_name_by_idx(f, ".", H5_INDEX_NAME, H5_ITER_INC, k, nullptr, 0, H5P_DEFAULT);
      if (len <= 0) continue;
      std::string name(static_cast<std::size_t>(len) + 1, '\0');
      H5Lget_name_by_idx(f, ".", H5_INDEX_NAME, H5_ITER_INC, k, name.data(), name.size(), H5P_DEFAULT);
      name.resize(static_cast<std::size_t>(len));
      const hid_t obj = H5Oopen(f, name.c_str(), H5P_DEFAULT);
      if (obj < 0) continue;
      if (H5Iget_type(obj) == H5I_DATASET) names.push_back(name);
      H5Oclose(obj);
    }
  for (const std::string& name : names) {
    Dataset d;
    const hid_t ds = H5Dopen2(f, name.c_str(), H5P_DEFAULT);
    const hid_t space = H5Dget_space(ds);
    const hid_t type = H5Dget_type(ds);
    const int rank = H5Sget_simple_extent_ndims(space);
    d.dims.resize(static_cast<std::size_t>(std::max(rank, 0)));
    if (rank > 0) H5Sget_simple_extent_dims(space, d.dims.data(), nullptr);
    const auto count = static_cast<std::size_t>(H5Sget_simple_extent_npoints(space));
    d.cls = H5Tget_class(type);
    d.type_size = H5Tget_size(type);
    d.bytes.resize(count * d.type_size);
    if (count > 0) H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, d.bytes.data());
    if (d.cls == H5T_FLOAT || d.cls == H5T_INTEGER) {
      d.values.resize(count);
      if (count > 0) H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, d.values.data());
    }
    H5Tclose(type);
    H5Sclose(space);
    H5Dclose(ds);
    out.emplace(name, std::move(d));
  }
  H5Fclose(f);
  return out;
}

std::string shape(const std::vector<hsize_t>& dims) {
  std::string s = "[";
  for (std::size_t k = 0; k < dims.size(); ++k) s += (k ? " x " : "") + std::to_string(dims[k]);
  return s + "]";
}

/// Bit-for-bit comparison of every dataset of `file` in two output folders. Returns "" when
/// identical; otherwise one line per difference (for numbers: how many entries differ and
/// the largest absolute and relative difference).
std::string compare_h5(const fs::path& a_dir, const fs::path& b_dir, const std::string& file) {
  const auto a = read_datasets(a_dir / file), b = read_datasets(b_dir / file);
  std::ostringstream r;
  if (a.empty()) r << file << ": no datasets in " << (a_dir / file) << "\n";
  if (b.empty()) r << file << ": no datasets in " << (b_dir / file) << "\n";
  for (const auto& [name, da] : a) {
    const auto it = b.find(name);
    if (it == b.end()) {
      r << file << " " << name << ": missing in " << b_dir << "\n";
      continue;
    }
    const Dataset& db = it->second;
    if (da.dims != db.dims || da.cls != db.cls || da.type_size != db.type_size) {
      r << file << " " << name << ": shape " << shape(da.dims) << " vs " << shape(db.dims)
        << " (type class " << da.cls << "/" << db.cls << ", size " << da.type_size << "/"
        << db.type_size << ")\n";
      continue;
    }
    if (da.bytes == db.bytes) continue;
    std::size_t differ = 0;
    double max_abs = 0.0, max_rel = 0.0;
    for (std::size_t k = 0; k < da.values.size(); ++k) {
      const double x = da.values[k], y = db.values[k];
      if (std::memcmp(&da.bytes[k * da.type_size], &db.bytes[k * db.type_size], da.type_size) == 0)
        continue;
      ++differ;
      const double d = std::abs(x - y);
      max_abs = std::max(max_abs, d);
      if (std::max(std::abs(x), std::abs(y)) > 0.0)
        max_rel = std::max(max_rel, d / std::max(std::abs(x), std::abs(y)));
    }
    r << file << " " << name << " " << shape(da.dims) << ": " << differ << " of "
      << da.values.size() << " entries differ, max |diff| " << max_abs << ", max rel " << max_rel
      << "\n";
  }
  for (const auto& [name, db] : b)
    if (!a.count(name)) r << file << " " << name << ": missing in " << a_dir << "\n";
  return r.str();
}

TEST(TwoProcess, ForeignRunIsIgnored) {
  ASSERT_TRUE(fs::exists(kPublisher)) << kPublisher;
  const fs::path dir = scratch("foreign_run");
  const fs::path scene = kSource / "scenes" / "coupled_small.toml";

  // Two clean runs: the reference, and a check that a clean run repeats itself bit for bit
  // (else a difference under foreign traffic would prove nothing).
  const fs::path clean = dir / "clean", clean2 = dir / "clean2", foreign = dir / "foreign";
  for (const fs::path& out : {clean, clean2}) {
    ASSERT_EQ(run_launcher(scene, out), 0) << logs(out);
    ASSERT_EQ(slurp(out / "fluid.exit"), "0\n") << logs(out);
    ASSERT_EQ(slurp(out / "solid.exit"), "0\n") << logs(out);
    EXPECT_EQ(foreign_count(slurp(out / "fluid.log")), 0) << logs(out);
    EXPECT_EQ(foreign_count(slurp(out / "solid.log")), 0) << logs(out);
  }
  for (const char* file : {"solid.h5", "monitor.h5"})
    ASSERT_EQ(compare_h5(clean, clean2, file), "")
        << "two clean runs of the same scene differ: the run is not reproducible";

  // The foreign run: the publisher (another token, every message type, the run's CGP count
  // and wrong ones, stop_t 0 and non-zero) runs from before the servers start until the
  // launcher stops it with SIGTERM after both have ended.
  const std::string extra = "exec " + quoted(kPublisher) + " --duration 600 --scene " +
                            quoted(scene.string());
  ASSERT_EQ(run_launcher(scene, foreign, extra), 0) << logs(foreign);
  EXPECT_EQ(slurp(foreign / "fluid.exit"), "0\n") << logs(foreign);
  EXPECT_EQ(slurp(foreign / "solid.exit"), "0\n") << logs(foreign);
  const std::string fluid_log = slurp(foreign / "fluid.log"), solid_log = slurp(foreign / "solid.log");
  EXPECT_NE(fluid_log.find("coupled run done, 200 LB steps"), std::string::npos) << logs(foreign);
  EXPECT_NE(solid_log.find("coupled run done"), std::string::npos) << logs(foreign);
  // The publisher ran and was stopped by the launcher: "sent N messages ... (signalled)".
  const std::string extra_log = slurp(foreign / "extra.log");
  EXPECT_NE(extra_log.find("(signalled)"), std::string::npos) << logs(foreign);
  const long long fluid_foreign = foreign_count(fluid_log), solid_foreign = foreign_count(solid_log);
  EXPECT_GT(fluid_foreign, 0) << logs(foreign);
  EXPECT_GT(solid_foreign, 0) << logs(foreign);
  std::printf("foreign messages counted: fluid %lld, solid %lld; %s", fluid_foreign, solid_foreign,
              extra_log.substr(extra_log.find("foreign_publisher: sent") == std::string::npos
                                   ? 0
                                   : extra_log.find("foreign_publisher: sent"))
                  .c_str());

  // Results unchanged, bit for bit (neither file holds a wall-clock quantity).
  for (const char* file : {"solid.h5", "monitor.h5"})
    EXPECT_EQ(compare_h5(clean, foreign, file), "") << "the foreign run changed " << file;

  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
