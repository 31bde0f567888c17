// The HDF5 cache of the RCGP construction (DESIGN 4.3 item 9): keyed by the inputs' hash,
// loaded bit for bit, rebuilt when corrupt, an error when it cannot be written.
#include "solid/rcgp/rcgp_cache.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>

namespace cosim::solid {
namespace {

namespace fs = std::filesystem;

/// A fresh folder under ::testing::TempDir(), removed at the end.
class ScratchDir {
 public:
  ScratchDir() {
    std::random_device rd;
    const std::string name = std::string("rcgp_cache_") +
                             ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" +
                             std::to_string(rd()) + std::to_string(rd());
    path_ = fs::path(::testing::TempDir()) / name;
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::size_t files_in(const fs::path& dir) {
  std::size_t n = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  return n;
}

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

void expect_same_kernel(const CgKernel& a, const CgKernel& b, const std::string& what) {
  EXPECT_EQ(a.ax_m, b.ax_m) << what;
  EXPECT_EQ(a.ay_m, b.ay_m) << what;
  EXPECT_EQ(a.range, b.range) << what;
  ASSERT_EQ(a.in_plane.size(), b.in_plane.size()) << what;
  ASSERT_EQ(a.flexural.size(), b.flexural.size()) << what;
  for (std::size_t i = 0; i < a.in_plane.size(); ++i) {
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c)
        EXPECT_EQ(a.in_plane[i](r, c), b.in_plane[i](r, c)) << what << " in_plane " << i << " " << r << c;
    EXPECT_EQ(a.flexural[i], b.flexural[i]) << what << " flexural " << i;
  }
}

void expect_same_moments(const KernelMoments& a, const KernelMoments& b, const std::string& what) {
  EXPECT_TRUE(a.in_plane_sum == b.in_plane_sum) << what;
  EXPECT_TRUE(a.in_plane_second == b.in_plane_second) << what;
  EXPECT_EQ(a.flexural_sum, b.flexural_sum) << what;
  EXPECT_TRUE(a.flexural_second == b.flexural_second) << what;
  EXPECT_TRUE(a.flexural_fourth == b.flexural_fourth) << what;
}

/// Every field equal with == (bit for bit for the numbers that are not NaN).
void expect_identical(const RcgpConstruction& a, const RcgpConstruction& b) {
  EXPECT_EQ(a.options.stages, b.options.stages);
  EXPECT_EQ(a.options.flexural_scaling, b.options.flexural_scaling);
  EXPECT_EQ(a.options.truncation_range, b.options.truncation_range);
  EXPECT_EQ(a.options.moment_matching, b.options.moment_matching);
  EXPECT_EQ(a.options.bending_poisson, b.options.bending_poisson);
  EXPECT_EQ(a.options.cache_dir, b.options.cache_dir);
  for (std::size_t s = 0; s < a.force_constants.shells.size(); ++s) {
    EXPECT_EQ(a.force_constants.shells[s].radial_N_m, b.force_constants.shells[s].radial_N_m) << s;
    EXPECT_EQ(a.force_constants.shells[s].tangential_in_N_m, b.force_constants.shells[s].tangential_in_N_m) << s;
    EXPECT_EQ(a.force_constants.shells[s].tangential_out_N_m, b.force_constants.shells[s].tangential_out_N_m)
        << s;
  }
  EXPECT_EQ(a.bond_length_m, b.bond_length_m);
  EXPECT_EQ(a.atom_mass_kg, b.atom_mass_kg);
  EXPECT_EQ(a.atomistic.c11_N_m, b.atomistic.c11_N_m);
  EXPECT_EQ(a.atomistic.c12_N_m, b.atomistic.c12_N_m);
  EXPECT_EQ(a.atomistic.c66_N_m, b.atomistic.c66_N_m);
  EXPECT_EQ(a.atomistic.youngs_modulus_N_m, b.atomistic.youngs_modulus_N_m);
  EXPECT_EQ(a.atomistic.poisson_ratio, b.atomistic.poisson_ratio);
  EXPECT_EQ(a.atomistic_kappa_J, b.atomistic_kappa_J);
  EXPECT_EQ(a.stage1_consistent_mass_kg, b.stage1_consistent_mass_kg);
  EXPECT_EQ(a.stage1_mass_identity_defect, b.stage1_mass_identity_defect);
  ASSERT_EQ(a.stages.size(), b.stages.size());
  for (std::size_t i = 0; i < a.stages.size(); ++i) {
    const RcgpStage& x = a.stages[i];
    const RcgpStage& y = b.stages[i];
    const std::string what = "stage " + std::to_string(i + 1);
    EXPECT_EQ(x.stage, y.stage) << what;
    expect_same_kernel(x.projected, y.projected, what + " projected");
    expect_same_kernel(x.kernel, y.kernel, what + " kernel");
    expect_same_moments(x.target, y.target, what + " target");
    EXPECT_EQ(x.lumped_mass_kg, y.lumped_mass_kg) << what;
    EXPECT_EQ(x.atoms_per_cgp, y.atoms_per_cgp) << what;
    EXPECT_EQ(x.translation_invariance_defect, y.translation_invariance_defect) << what;
    EXPECT_EQ(x.constants.c11_N_m, y.constants.c11_N_m) << what;
    EXPECT_EQ(x.constants.c22_N_m, y.constants.c22_N_m) << what;
    EXPECT_EQ(x.constants.c12_N_m, y.constants.c12_N_m) << what;
    EXPECT_EQ(x.constants.c66_N_m, y.constants.c66_N_m) << what;
    EXPECT_EQ(x.constants.d11_J, y.constants.d11_J) << what;
    EXPECT_EQ(x.constants.d22_J, y.constants.d22_J) << what;
    EXPECT_EQ(x.constants.d_mixed_J, y.constants.d_mixed_J) << what;
    EXPECT_EQ(x.spectrum.in_plane_min_rel, y.spectrum.in_plane_min_rel) << what;
    EXPECT_EQ(x.spectrum.flexural_min_rel, y.spectrum.flexural_min_rel) << what;
    EXPECT_EQ(x.spectrum.in_plane_max_N_m, y.spectrum.in_plane_max_N_m) << what;
    EXPECT_EQ(x.spectrum.flexural_max_N_m, y.spectrum.flexural_max_N_m) << what;
    EXPECT_EQ(x.stable_time_step_s, y.stable_time_step_s) << what;
  }
}

RcgpOptions small_options(const fs::path& cache_dir) {
  RcgpOptions opt;
  opt.stages = 3;
  opt.cache_dir = cache_dir.string();
  return opt;
}

TEST(RcgpCache, ConstructionIsCachedByInputHash) {
  const ScratchDir scratch;
  const fs::path dir = scratch.path() / "cache" / "rcgp";  // created by the first call
  const RcgpOptions opt = small_options(dir);
  const ForceConstantModel atoms;
  const std::string file = rcgp_cache_file(opt, atoms);
  EXPECT_EQ(fs::path(file), dir / ("rcgp-" + rcgp_input_hash(opt, atoms) + ".h5"));

  std::string how;
  const RcgpConstruction built = load_or_build_rcgp(opt, atoms, &how);
  EXPECT_TRUE(starts_with(how, "built in ")) << how;
  EXPECT_NE(how.find("cached in " + file), std::string::npos) << how;
  ASSERT_TRUE(fs::is_regular_file(file));
  EXPECT_EQ(files_in(dir), 1u);  // no temporary left behind

  const RcgpConstruction loaded = load_or_build_rcgp(opt, atoms, &how);
  EXPECT_EQ(how, "loaded from " + file);
  expect_identical(built, loaded);
  expect_identical(built, load_rcgp(file));
  // The cache gives what build_rcgp gives.
  expect_identical(build_rcgp(opt, atoms), loaded);

  // An option the construction does not depend on hits the same file and comes back as
  // asked.
  RcgpOptions poisson = opt;
  poisson.bending_poisson = 0.25;
  EXPECT_EQ(rcgp_cache_file(poisson, atoms), file);
  EXPECT_EQ(load_or_build_rcgp(poisson, atoms, &how).options.bending_poisson, 0.25);
  EXPECT_EQ(how, "loaded from " + file);

  // One that it depends on gives another file.
  RcgpOptions physical = opt;
  physical.flexural_scaling = FlexuralScaling::Physical;
  const std::string file2 = rcgp_cache_file(physical, atoms);
  EXPECT_NE(file2, file);
  const RcgpConstruction built2 = load_or_build_rcgp(physical, atoms, &how);
  EXPECT_TRUE(starts_with(how, "built in ")) << how;
  EXPECT_NE(how.find(file2), std::string::npos) << how;
  EXPECT_NE(built2.final_stage().kernel.flexural, built.final_stage().kernel.flexural);
  EXPECT_EQ(files_in(dir), 2u);
  const RcgpConstruction loaded2 = load_or_build_rcgp(physical, atoms, &how);
  EXPECT_EQ(how, "loaded from " + file2);
  expect_identical(built2, loaded2);

  // No cache_dir: a plain build, no file.
  RcgpOptions no_cache = opt;
  no_cache.cache_dir.clear();
  EXPECT_EQ(rcgp_cache_file(no_cache, atoms), "");
  EXPECT_EQ(load_or_build_rcgp(no_cache, atoms, &how).final_stage().kernel.flexural,
            built.final_stage().kernel.flexural);
  EXPECT_TRUE(starts_with(how, "built in ")) << how;
  EXPECT_EQ(files_in(dir), 2u);
}

TEST(RcgpCache, CorruptCacheIsRebuilt) {
  const ScratchDir scratch;
  const RcgpOptions opt = small_options(scratch.path());
  const ForceConstantModel atoms;
  const std::string file = rcgp_cache_file(opt, atoms);
  std::string how;
  const RcgpConstruction built = load_or_build_rcgp(opt, atoms, &how);
  ASSERT_TRUE(fs::is_regular_file(file)) << how;

  // Truncated.
  fs::resize_file(file, fs::file_size(file) / 2);
  EXPECT_THROW(load_rcgp(file), std::runtime_error);
  const RcgpConstruction after_truncation = load_or_build_rcgp(opt, atoms, &how);
  EXPECT_TRUE(starts_with(how, "built in ")) << how;
  EXPECT_NE(how.find("replaced an unusable cache file"), std::string::npos) << how;
  expect_identical(built, after_truncation);
  expect_identical(built, load_or_build_rcgp(opt, atoms, &how));
  EXPECT_EQ(how, "loaded from " + file);

  // Garbage.
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << "this is not an HDF5 file\n";
  }
  try {
    load_rcgp(file);
    ADD_FAILURE() << "load_rcgp read garbage";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
  }
  const RcgpConstruction after_garbage = load_or_build_rcgp(opt, atoms, &how);
  EXPECT_TRUE(starts_with(how, "built in ")) << how;
  EXPECT_NE(how.find("replaced an unusable cache file"), std::string::npos) << how;
  expect_identical(built, after_garbage);

  // A valid file of other inputs under this name.
  RcgpOptions physical = opt;
  physical.flexural_scaling = FlexuralScaling::Physical;
  save_rcgp(build_rcgp(physical, atoms), file);
  const RcgpConstruction after_mismatch = load_or_build_rcgp(opt, atoms, &how);
  EXPECT_NE(how.find("input hash"), std::string::npos) << how;
  expect_identical(built, after_mismatch);
  expect_identical(built, load_or_build_rcgp(opt, atoms, &how));
  EXPECT_EQ(how, "loaded from " + file);
  EXPECT_EQ(files_in(scratch.path()), 1u);
}

TEST(RcgpCache, UnwritableCacheDirIsAnError) {
  const ScratchDir scratch;
  const fs::path plain = scratch.path() / "plain-file";
  { std::ofstream(plain) << "not a folder\n"; }
  const auto expect_error_naming = [](const RcgpOptions& opt, const std::string& path) {
    try {
      load_or_build_rcgp(opt);
      ADD_FAILURE() << "no error for cache_dir " << opt.cache_dir;
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  };
  expect_error_naming(small_options(plain), plain.string());
  expect_error_naming(small_options(plain / "below"), (plain / "below").string());

  // The building blocks name their file too.
  const fs::path missing = scratch.path() / "no-such-folder" / "rcgp.h5";
  RcgpOptions no_cache = small_options(scratch.path());
  no_cache.cache_dir.clear();
  try {
    save_rcgp(build_rcgp(no_cache), missing.string());
    ADD_FAILURE() << "save_rcgp wrote into a missing folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
  }
  try {
    load_rcgp(missing.string());
    ADD_FAILURE() << "load_rcgp read a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::solid
