// A foreign run on the same channels (protocol/README.md sections 6-8): a second publisher
// (tests/integration/foreign_publisher.cpp) sends messages of every type with another run token while
// the coupled scene runs through launch/run-coupled.sh (--extra: inside the run's private
// network namespace). Both servers count them ("foreign N" in their final counters line),
// never apply them, never answer them: the run completes and its results (every dataset of
// solid.h5 and monitor.h5) are bit for bit those of a clean run.
#include <gtest/gtest.h>

#include "tests/support/run_compare.hpp"

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

using cosim::test::compare_h5;
using cosim::test::logs;
using cosim::test::quoted;
using cosim::test::scratch;
using cosim::test::slurp;

int run_launcher(const fs::path& scene, const fs::path& output, const std::string& extra = "") {
  return cosim::test::run_launcher(kSource, scene, output, extra.empty() ? "" : "--extra " + quoted(extra));
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
