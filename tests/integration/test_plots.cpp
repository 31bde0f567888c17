// launch/plot.py over a coupled run: the small coupled scene through launch/run-coupled.sh,
// then the plots (valid PNGs of non-trivial size), and a one-line error with exit 2 for a
// folder that is not a run's output; launch/paper-figures.sh --tiny, every figure of the
// paper's section 3 (Figs. 5-14) and the index page.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;

const fs::path kSource = COSIM_SOURCE_DIR;
const char* const kPython = "/usr/bin/python3";  // Debian's, with h5py and matplotlib

using cosim::test::contains;
using cosim::test::quoted;
using cosim::test::run_command;
using cosim::test::RunResult;
using cosim::test::slurp;

fs::path scratch(const std::string& name) { return cosim::test::fresh_scratch("cosim_" + name); }

int run(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

bool is_png(const fs::path& p) {
  static const std::array<unsigned char, 8> kSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::ifstream in(p, std::ios::binary);
  std::array<char, 8> head{};
  if (!in.read(head.data(), head.size())) return false;
  for (std::size_t i = 0; i < head.size(); ++i)
    if (static_cast<unsigned char>(head[i]) != kSignature[i]) return false;
  return true;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(line);
  return out;
}

TEST(Plots, PlotsAreProduced) {
  if (!fs::exists(kPython)) GTEST_SKIP() << kPython << " missing (launch/bootstrap.sh installs it)";
  const fs::path dir = scratch("plots");
  const fs::path run_dir = dir / "run";
  fs::create_directories(run_dir);
  const fs::path plot = kSource / "launch" / "plot.py";

  // The coupled small scene, two processes over LCM.
  const int launched = run("bash " + (kSource / "launch" / "run-coupled.sh").string() + " " +
                           (kSource / "scenes" / "coupled_small.toml").string() + " --output " +
                           run_dir.string() + " --no-build --quiet >" + (dir / "launcher.log").string() +
                           " 2>&1");
  ASSERT_EQ(launched, 0) << slurp(dir / "launcher.log") << slurp(run_dir / "fluid.log")
                         << slurp(run_dir / "solid.log");
  ASSERT_TRUE(fs::exists(run_dir / "solid.h5"));

  // The plots: exit 0, every file listed on stdout, each a PNG of non-trivial size.
  const fs::path plots = run_dir / "plots";
  const int plotted = run(std::string(kPython) + " " + plot.string() + " " + run_dir.string() +
                          " --out " + plots.string() + " >" + (dir / "plot.out").string() + " 2>" +
                          (dir / "plot.err").string());
  ASSERT_EQ(plotted, 0) << slurp(dir / "plot.out") << slurp(dir / "plot.err");
  EXPECT_EQ(slurp(dir / "plot.err"), "");
  const std::string listed = slurp(dir / "plot.out");
  // coupled_small writes field snapshots (fields_every = 50), hence the vorticity plane, and
  // sheet snapshots (sheets_every = 50), hence the strain on the sheets (Fig. 11).
  const std::vector<std::string> expected = {"displacement.png", "coefficients.png", "forces.png",
                                             "strain.png",       "energy.png",       "monitor.png",
                                             "strain_sheets.png", "vorticity_y.png"};
  for (const auto& name : expected) {
    const fs::path p = plots / name;
    ASSERT_TRUE(fs::exists(p)) << name << " missing; plot.py printed:\n" << listed;
    EXPECT_TRUE(is_png(p)) << name << " does not start with the PNG signature";
    EXPECT_GT(fs::file_size(p), 20000u) << name << " is suspiciously small";
    EXPECT_NE(listed.find(p.string()), std::string::npos) << name << " not listed:\n" << listed;
    // The vector twin beside it (--formats png,pdf by default).
    const fs::path pdf = fs::path(p).replace_extension(".pdf");
    ASSERT_TRUE(fs::exists(pdf)) << pdf;
    EXPECT_EQ(slurp(pdf).rfind("%PDF-", 0), 0u) << pdf;
    EXPECT_NE(listed.find(pdf.string()), std::string::npos) << pdf << " not listed:\n" << listed;
  }
  EXPECT_EQ(lines_of(listed).size(), 2 * expected.size()) << listed;

  // --stats: one tab-separated row for the one sheet.
  const int stats = run(std::string(kPython) + " " + plot.string() + " --stats " + run_dir.string() +
                        " >" + (dir / "stats.out").string() + " 2>&1");
  EXPECT_EQ(stats, 0) << slurp(dir / "stats.out");
  const auto rows = lines_of(slurp(dir / "stats.out"));
  ASSERT_EQ(rows.size(), 1u) << slurp(dir / "stats.out");
  EXPECT_EQ(rows[0].rfind("coupled_small\tG1\t", 0), 0u) << rows[0];

  // A folder that is not a run's output: exit 2, one line on stderr naming solid.h5, no
  // traceback, nothing on stdout.
  const fs::path empty = dir / "empty";
  fs::create_directories(empty);
  const int failed = run(std::string(kPython) + " " + plot.string() + " " + empty.string() + " --out " +
                         (dir / "empty_plots").string() + " >" + (dir / "empty.out").string() + " 2>" +
                         (dir / "empty.err").string());
  EXPECT_EQ(failed, 2);
  const std::string err = slurp(dir / "empty.err");
  const auto err_lines = lines_of(err);
  EXPECT_EQ(err_lines.size(), 1u) << err;
  EXPECT_NE(err.find("solid.h5"), std::string::npos) << err;
  EXPECT_EQ(err.find("Traceback"), std::string::npos) << err;
  EXPECT_EQ(slurp(dir / "empty.out"), "");
  EXPECT_FALSE(fs::exists(dir / "empty_plots"));

  fs::remove_all(dir);
}

// ---- the paper's figures ----

TEST(Plots, PaperFiguresScriptProducesEveryFigure) {
  const fs::path dir = scratch("paper_figures");
  const fs::path out = dir / "figs";
  // --tiny: one run of each family, the reduced presets cut to 40 LB steps, then every figure.
  const RunResult r = run_command("bash " + quoted((kSource / "launch" / "paper-figures.sh").string()) +
                                      " --tiny --no-build --out " + quoted(out.string()),
                                  dir / "script");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const fs::path figures = out / "figures";
  for (const char* fig : {"fig05_displacement_re", "fig06_coefficients_re", "fig07_displacement_angle",
                          "fig08_forces_angle", "fig09_vorticity_single_theta30_re40",
                          "fig10_displacement_pair", "fig11_strain_sheets",
                          "fig12_vorticity_t13.8", "fig12_vorticity_t15.6", "fig12_vorticity_t22.7",
                          "fig13_forces_pair", "fig14_strain_pair"}) {
    for (const char* ext : {".png", ".pdf"}) {
      const fs::path p = figures / (std::string(fig) + ext);
      ASSERT_TRUE(fs::exists(p)) << p << "\n" << r.out << r.err;
      EXPECT_GT(fs::file_size(p), 5000u) << p;
    }
  }
  // The index page shows every figure, Figs. 5 to 14.
  const std::string index = slurp(figures / "index.html");
  for (int n = 5; n <= 14; ++n) EXPECT_TRUE(contains(index, "<h2>Fig. " + std::to_string(n) + ": ")) << n;
  EXPECT_TRUE(contains(index, "fig11_strain_sheets.png")) << index;
  EXPECT_TRUE(contains(index, "launch/plot.py")) << index;
  fs::remove_all(dir);
}

}  // namespace
