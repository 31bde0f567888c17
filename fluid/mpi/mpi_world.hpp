// MPI for the fluid (DESIGN 8): started only when mpirun launched the process, so that the
// fluid of a build with MPI runs alone exactly as one without it.
#pragma once

#include <mpi.h>

#include <string>

namespace cosim::fluid::mpi {

/// Whether this process was started by mpirun (OpenMPI's or a PMI launcher's environment).
bool launched_by_mpirun();

/// MPI_Init_thread (funneled: OpenMP threads never call MPI) for the lifetime of the object;
/// MPI_Finalize at the end. Errors on the world communicator return (MPI_ERRORS_RETURN) and
/// are thrown as std::runtime_error by check().
class World {
 public:
  World(int& argc, char**& argv);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  MPI_Comm comm() const { return MPI_COMM_WORLD; }
  /// Ends every rank of the run (a rank that cannot go on must not leave the others waiting
  /// in a collective).
  [[noreturn]] static void abort(int code);

 private:
  int rank_ = 0, size_ = 1;
};

/// Throws std::runtime_error naming `what` and MPI's error string unless rc is MPI_SUCCESS.
void check(int rc, const char* what);

/// The leader's (rank 0) text on every rank.
std::string broadcast(MPI_Comm comm, const std::string& text);

}  // namespace cosim::fluid::mpi
