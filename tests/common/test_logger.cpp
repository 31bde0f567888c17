// The one logger (common/log/logger.hpp): the process's prefix, the levels and their
// threshold (--quiet), the progress line's format, whole lines from several threads.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/log/logger.hpp"

namespace {

using cosim::log::Level;
using cosim::log::Logger;

TEST(Logger, PrefixesEachLineWithTheProcessAndTheLevelsWord) {
  std::ostringstream os;
  const Logger log("fluid");
  log.info(os) << "handshake accepted: " << 3 << " CGPs";
  log.warning(os) << "added mass: light";
  log.error(os) << "scene.toml: not a coupled scene";
  log.progress(os) << "step 1/2";
  EXPECT_EQ(os.str(),
            "fluid: handshake accepted: 3 CGPs\n"
            "fluid: warning: added mass: light\n"
            "fluid: scene.toml: not a coupled scene\n"
            "fluid: progress step 1/2\n");
  EXPECT_EQ(log.prefix(), "fluid: ");
  EXPECT_EQ(log.format(Level::progress, "step 2/2"), "fluid: progress step 2/2");
}

TEST(Logger, QuietThresholdDropsProgressAndDebugOnly) {
  std::ostringstream os;
  const Logger quiet = Logger("solid").at(Level::info);
  quiet.progress(os) << "step 1/2";
  quiet.debug(os) << "detail";
  quiet.info(os) << "done";
  quiet.error(os) << "stopped";
  EXPECT_EQ(os.str(), "solid: done\nsolid: stopped\n");
  EXPECT_FALSE(Logger("solid").shows(Level::debug));
  EXPECT_TRUE(Logger("solid", Level::debug).shows(Level::debug));
}

TEST(Logger, LinesFromSeveralThreadsStayWhole) {
  std::ostringstream os;
  const Logger log("fluid");
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int k = 0; k < 200; ++k) log.info(os) << "thread " << t << " line " << k << " of 200";
    });
  for (std::thread& t : threads) t.join();
  std::istringstream in(os.str());
  std::string line;
  int lines = 0;
  while (std::getline(in, line)) {
    ++lines;
    EXPECT_EQ(line.rfind("fluid: thread ", 0), 0u) << line;
    EXPECT_EQ(line.substr(line.size() - 7), " of 200") << line;
  }
  EXPECT_EQ(lines, 800);
}

TEST(Logger, PrintfTextHasNoLengthLimit) {
  const std::string long_text(600, 'x');
  EXPECT_EQ(cosim::log::printf_text("%s %d", long_text.c_str(), 7), long_text + " 7");
}

}  // namespace
