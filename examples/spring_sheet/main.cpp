// spring_sheet: the spring-network sheet of spring_sheet.hpp as a solid process, on the
// solid library: the launcher's command line, the handshake, the lock-step and the exit codes
// are the library's (cosim::sdk::run).
//   bash launch/run-coupled.sh scenes/coupled_spring_sheet.toml
//       --solid-cmd "build/examples/spring_sheet/spring_sheet --stiffness 0.02"
#include "spring_sheet.hpp"

int main(int argc, char** argv) {
  spring_sheet::SpringSheet sheet;
  return cosim::sdk::run(sheet, argc, argv);
}
