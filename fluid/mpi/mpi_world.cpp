#include "fluid/mpi/mpi_world.hpp"

#include "fluid/domain/decomposition.hpp"

#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace cosim::fluid::mpi {

bool launched_by_mpirun() { return mpirun_world_size() > 0; }

World::World(int& argc, char**& argv) {
  int provided = 0;
  check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

World::~World() { MPI_Finalize(); }

void World::abort(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);
}

void check(int rc, const char* what) {
  if (rc == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(rc, text, &len);
  throw std::runtime_error(std::string("MPI: ") + what + ": " + std::string(text, std::size_t(len)));
}

std::string broadcast(MPI_Comm comm, const std::string& text) {
  long long n = static_cast<long long>(text.size());
  check(MPI_Bcast(&n, 1, MPI_LONG_LONG, 0, comm), "MPI_Bcast");
  std::string out = text;
  out.resize(std::size_t(n));
  if (n > 0) check(MPI_Bcast(out.data(), int(n), MPI_CHAR, 0, comm), "MPI_Bcast");
  return out;
}

}  // namespace cosim::fluid::mpi
