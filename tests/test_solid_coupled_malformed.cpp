// The solid server's coupled run against malformed messages (protocol/README.md 8a), with
// the fake fluid of tests/solid_coupled_support.hpp over memq://.
#include "solid_coupled_support.hpp"

namespace {

std::map<std::string, std::vector<double>> solid_h5(const fs::path& file) {
  std::map<std::string, std::vector<double>> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  for (const char* name :
       {"step", "time_s", "solid_time_s", "marked_displacement_um", "marked_normal_displacement_um",
        "fluid_force_N", "bulk_velocity_m_s", "force_coefficients", "leading_edge_strain",
        "kinetic_energy_J", "elastic_energy_J", "total_energy_J"}) {
    const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    if (d < 0) continue;
    const hid_t space = H5Dget_space(d);
    std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
    if (!v.empty()) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Sclose(space);
    H5Dclose(d);
    out.emplace(name, std::move(v));
  }
  H5Fclose(f);
  return out;
}

template <class M>
std::vector<std::uint8_t> encoded(const M& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

// Message security (protocol/README.md section 8a): malformed fluid_state_t copies mixed with
// the valid ones (a NaN, rho = 0, a step far ahead; bytes with a hostile num_cgps, a token
// length of 0, a truncation) are counted, logged once, never applied: the run completes with
// the solid.h5 of a clean run, bit for bit. Only refused copies of a step end the run, after
// kRejectedCopiesLimit (3) of them, naming the field.
TEST(SolidCoupled, MalformedMessagesAreRejected) {
  const fs::path clean_dir = scratch_dir("clean"), noisy_dir = scratch_dir("noisy");
  const SolidScene clean_scene = cosim::solid::load_solid_scene(write_scene(clean_dir, 1).string());
  const SolidScene noisy_scene = cosim::solid::load_solid_scene(write_scene(noisy_dir, 1).string());
  lcm::LCM clean_bus("memq://"), noisy_bus("memq://");
  FakeFluid clean(clean_bus, clean_scene, 5), noisy(noisy_bus, noisy_scene, 5);
  noisy.before = [](const cosimlcm::fluid_state_t& good) {
    std::vector<std::vector<std::uint8_t>> out;
    cosimlcm::fluid_state_t m = good;
    m.velocity_lb[4][1] = std::nan("");
    out.push_back(encoded(m));
    m = good;
    m.rho_lb[0] = 0.0;
    out.push_back(encoded(m));
    m = good;
    m.step += 20;
    out.push_back(encoded(m));
    std::vector<std::uint8_t> hostile = encoded(good);
    // num_cgps after the hash (8), the token (4 + 17), seq, step, iteration,
    // bulk_velocity_lb (28).
    const std::size_t at = 8 + 4 + 17 + 28;
    hostile[at] = 0x7f, hostile[at + 1] = hostile[at + 2] = hostile[at + 3] = 0xff;
    out.push_back(hostile);
    std::vector<std::uint8_t> no_token = encoded(good);
    no_token[8] = no_token[9] = no_token[10] = no_token[11] = 0;
    out.push_back(no_token);
    std::vector<std::uint8_t> cut = encoded(good);
    cut.resize(cut.size() - 9);
    out.push_back(cut);
    return out;
  };
  const Outcome c = run_solid(clean_scene, clean_bus);
  ASSERT_EQ(c.code, 0) << c.out << c.err;
  const Outcome n = run_solid(noisy_scene, noisy_bus);
  ASSERT_EQ(n.code, 0) << n.out << n.err;
  EXPECT_EQ(n.err, "");
  EXPECT_EQ(counter(c.out, "rejected"), 0) << c.out;
  EXPECT_EQ(counter(n.out, "rejected"), 3 * 4) << n.out;     // fluid_state_t 1..4
  EXPECT_EQ(counter(n.out, "undecodable"), 3 * 4) << n.out;
  EXPECT_NE(n.out.find("rejected 12 (non-finite 4, range 8)"), std::string::npos) << n.out;
  EXPECT_NE(n.out.find("solid: refusing messages on channel 'TEST_FLUID_STATE' (non-finite): "
                       "fluid_state_t: velocity_lb[4][1] = nan; every number must be finite; such "
                       "messages are counted, never applied"),
            std::string::npos)
      << n.out;
  EXPECT_NE(n.out.find("does not decode as fluid_state_t (fluid_state_t: num_cgps = 2147483647 needs"),
            std::string::npos)
      << n.out;
  // The same solid_state_t went out, and the same solid.h5 came out.
  ASSERT_EQ(clean.states.size(), 5u);
  std::map<std::int64_t, const cosimlcm::solid_state_t*> first;
  for (const auto& m : noisy.states) first.emplace(m.step, &m);
  ASSERT_EQ(first.size(), 5u);
  for (const auto& m : clean.states)
    EXPECT_EQ(encoded(m), encoded(*first[m.step])) << "solid_state_t of step " << m.step;
  const auto a = solid_h5(clean_dir / "out" / "solid.h5"), b = solid_h5(noisy_dir / "out" / "solid.h5");
  ASSERT_EQ(a.size(), 12u);
  for (const auto& [name, values] : a) {
    ASSERT_EQ(b.count(name), 1u) << name;
    ASSERT_EQ(values.size(), b.at(name).size()) << name;
    EXPECT_EQ(std::memcmp(values.data(), b.at(name).data(), values.size() * sizeof(double)), 0) << name;
  }

  // Only refused copies of step 2 (every copy with seq = -1): the third ends the run with 2.
  const fs::path dir = scratch_dir("refused");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 1).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 5);
  fluid.corrupt = [](cosimlcm::fluid_state_t& f) {
    if (f.step == 2) f.seq = -1;
  };
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "solid: fluid_state_t of step 2: seq = -1; allowed: 0 or more (the sender's "
                   "counter) (3 copies refused)\n");
  EXPECT_EQ(fluid.states.size(), 2u);
  ASSERT_EQ(fluid.solid_stops(), 3u);
  EXPECT_EQ(fluid.stops.back().exit_code, 2);
  int asked = 0;
  for (const auto& m : fluid.resends) asked += m.what == "fluid_state" && m.step == 2;
  EXPECT_GE(asked, 2) << "each refused copy is asked for again";

  // Only refused welcome_t (the coordinator answers each hello_t with one): exit 2 after 3.
  const fs::path wdir = scratch_dir("welcome");
  const SolidScene wscene = cosim::solid::load_solid_scene(write_scene(wdir, 1).string());
  lcm::LCM wbus("memq://");
  FakeFluid zero(wbus, wscene, 0);  // welcome_t.total_steps = 0
  const Outcome w = run_solid(wscene, wbus);
  EXPECT_EQ(w.code, 2) << w.out << w.err;
  EXPECT_EQ(w.err, "solid: welcome_t: total_steps = 0; allowed: 1 or more (3 copies refused)\n");
  EXPECT_EQ(zero.hellos.size(), 3u);
  EXPECT_TRUE(zero.states.empty());
  for (const fs::path& d : {clean_dir, noisy_dir, dir, wdir}) fs::remove_all(d);
}

}  // namespace
