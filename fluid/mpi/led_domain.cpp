#include "fluid/mpi/led_domain.hpp"

#include <time.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <stdexcept>

#include "fluid/mpi/mpi_world.hpp"

namespace cosim::fluid::mpi {

namespace {

/// The calls rank 0 orders.
enum class Call : std::int64_t {
  Initialize = 1,
  Step,
  BeginStep,
  FinishStep,
  Schedule,
  KernelProblem,
  Summary,
  WriteSnapshots,
  FromLeader,
  Sample,
  Spread,
  Keep,
  RestoreKept,
  WriteStore,
  ReadStore,
  PeakMemory,
  End,
};

/// One order: the call and its scalar arguments (the same on every rank: the rest travels
/// inside the call).
struct Order {
  std::int64_t call = 0;
  std::int64_t arg = 0;  ///< schedule, step, kept, exit code
  double limits[4] = {0, 0, 0, 0};
};

/// A nonblocking broadcast on both sides (a blocking one would not match the followers').
void send(MPI_Comm orders, const Order& o) {
  Order copy = o;
  MPI_Request req;
  check(MPI_Ibcast(&copy, int(sizeof copy), MPI_BYTE, 0, orders, &req), "MPI_Ibcast (an order to the ranks)");
  check(MPI_Wait(&req, MPI_STATUS_IGNORE), "MPI_Wait (an order to the ranks)");
}

/// The next order, waited for without spinning: a nonblocking broadcast tested with sleeps
/// that grow from 20 us to 2 ms (the ranks wait so while the solid computes, on the same
/// cores).
Order receive(MPI_Comm orders) {
  Order o;
  MPI_Request req;
  check(MPI_Ibcast(&o, int(sizeof o), MPI_BYTE, 0, orders, &req), "MPI_Ibcast (an order from rank 0)");
  long sleep_ns = 20'000;
  for (;;) {
    int done = 0;
    check(MPI_Test(&req, &done, MPI_STATUS_IGNORE), "MPI_Test (an order from rank 0)");
    if (done) return o;
    const timespec t{0, sleep_ns};
    nanosleep(&t, nullptr);
    sleep_ns = std::min(2 * sleep_ns, 2'000'000L);
  }
}

Order order(Call c, std::int64_t arg = 0) {
  Order o;
  o.call = static_cast<std::int64_t>(c);
  o.arg = arg;
  return o;
}

}  // namespace

LedDomain::~LedDomain() {
  if (!ended_) {
    try {
      end(1);
    } catch (...) {
    }
  }
}

void LedDomain::end(int code) {
  if (ended_) return;
  ended_ = true;
  send(orders_, order(Call::End, code));
}

void LedDomain::initialize(const FluidScene& scene) {
  send(orders_, order(Call::Initialize));
  grid_.initialize(scene);
}
void LedDomain::step() {
  send(orders_, order(Call::Step));
  grid_.step();
}
void LedDomain::begin_step() {
  send(orders_, order(Call::BeginStep));
  grid_.begin_step();
}
void LedDomain::finish_step() {
  send(orders_, order(Call::FinishStep));
  grid_.finish_step();
}
void LedDomain::set_row_schedule(RowSchedule schedule) {
  send(orders_, order(Call::Schedule, static_cast<std::int64_t>(schedule)));
  grid_.set_row_schedule(schedule);
}
std::string LedDomain::kernel_problem(const HealthLimits& limits) {
  Order o = order(Call::KernelProblem);
  const double l[4] = {limits.mach_limit, limits.rho_floor, limits.rho_min, limits.rho_max};
  std::memcpy(o.limits, l, sizeof l);
  send(orders_, o);
  return grid_.kernel_problem(limits);
}
std::optional<FlowSummary> LedDomain::summary() {
  send(orders_, order(Call::Summary));
  return grid_.summary();
}
void LedDomain::write_snapshots(Snapshots& s, bool last) {
  send(orders_, order(Call::WriteSnapshots, last ? 1 : 0));
  grid_.write_snapshots(s, last);
}
std::string LedDomain::from_leader(const std::string& text) {
  send(orders_, order(Call::FromLeader));
  return grid_.from_leader(text);
}
void LedDomain::sample(std::span<const Vec3> X, std::span<MarkerSample> out) {
  send(orders_, order(Call::Sample));
  grid_.sample(X, out);
}
void LedDomain::spread(std::span<const Vec3> X, std::span<const Vec3> J) {
  send(orders_, order(Call::Spread));
  grid_.spread(X, J);
}
void LedDomain::keep_state() {
  send(orders_, order(Call::Keep));
  grid_.keep_state();
}
void LedDomain::restore_kept(std::int64_t step) {
  send(orders_, order(Call::RestoreKept, step));
  grid_.restore_kept(step);
}
std::string LedDomain::write_store(bool kept, const std::string& file, const std::string& name) {
  send(orders_, order(Call::WriteStore, kept ? 1 : 0));
  return grid_.write_store(kept, file, name);
}
std::string LedDomain::read_store(const std::string& file, const std::string& name, std::int64_t step) {
  send(orders_, order(Call::ReadStore, step));
  return grid_.read_store(file, name, step);
}

std::vector<double> LedDomain::peak_memory_mib() {
  send(orders_, order(Call::PeakMemory));
  return grid_.peak_memory_mib();
}

int follow(DistributedFluid& grid, const FluidScene& scene, double dt_us, MPI_Comm orders) {
  std::vector<MarkerSample> no_samples;
  std::optional<Snapshots> snapshots;
  for (;;) {
    const Order o = receive(orders);
    switch (static_cast<Call>(o.call)) {
      case Call::Initialize: grid.initialize(scene); break;
      case Call::Step: grid.step(); break;
      case Call::BeginStep: grid.begin_step(); break;
      case Call::FinishStep: grid.finish_step(); break;
      case Call::Schedule: grid.set_row_schedule(static_cast<RowSchedule>(o.arg)); break;
      case Call::KernelProblem:
        grid.kernel_problem(HealthLimits{o.limits[0], o.limits[1], o.limits[2], o.limits[3]});
        break;
      case Call::Summary: grid.summary(); break;
      case Call::WriteSnapshots:
        if (!snapshots) snapshots.emplace(scene, dt_us);
        try {
          grid.write_snapshots(*snapshots, o.arg != 0);
        } catch (const std::exception&) {
          // The same error on rank 0 (FieldWriter::write), which reports it.
        }
        break;
      case Call::FromLeader: grid.from_leader(std::string()); break;
      case Call::Sample: grid.sample({}, no_samples); break;
      case Call::Spread: grid.spread({}, {}); break;
      case Call::Keep: grid.keep_state(); break;
      case Call::RestoreKept: grid.restore_kept(o.arg); break;
      case Call::WriteStore: grid.write_store(o.arg != 0, std::string(), std::string()); break;
      case Call::ReadStore: grid.read_store(std::string(), std::string(), o.arg); break;
      case Call::PeakMemory: grid.peak_memory_mib(); break;
      case Call::End: return static_cast<int>(o.arg);
      default:
        throw std::runtime_error("rank " + std::to_string(grid.place().rank()) + ": an unknown order " +
                                 std::to_string(o.call) + " from rank 0");
    }
  }
}

}  // namespace cosim::fluid::mpi
