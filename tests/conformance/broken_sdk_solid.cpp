// A deliberately broken solid on the solid library for the conformance kit's tests
// (tests/integration/test_conformance.cpp): the spring sheet of examples/spring_sheet/spring_sheet.hpp
// with planted defects chosen by --fault F[,F2...], from LB step --from on (default: every step):
//   none             correct (the example itself)
//   double           J x 2
//   half             J x 1/2
//   over-time-ratio  J / A_T once more
//   late             J of the previous LB step (one exchange late; the first step its own)
//   frozen           X_l the start positions while J follows the motion
//   end-of-step      X_l the positions at the interval's end, not the substeps' mean
//   reaction-sign    the markers receive +g dA instead of -g dA (J = g dA as it should be)
//   half-reaction    the markers receive -g dA / 2 while J = g dA as it should be (its energy
//                    and its impulses disagree: with with-energy, the kit's energy balance)
//   double-reaction  the markers receive -2 g dA while J = g dA
//   restore-nothing  restore() keeps the state it has
//   um               X_l in micrometres instead of dx (the library's X_l(0) stays in dx)
//   exit-early       exits 0 in the middle of the run (at LB step --from) without a word
//   linger           does not exit after the fluid's stop_t (sleeps until it is stopped)
//   mis-sized        one position and one impulse fewer than markers (exit code 3)
//   with-energy      the sheet's energy hook (Solid::energy_lb) given: the library then
//                    checks its energy balance itself (by default withheld, so that the
//                    kit's own checks meet each fault; with reaction-sign: the library's
//                    balance names it, without: the coordinator's)
//   broken_sdk_solid SCENE --fault F [--from STEP] [the library's command line]
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "spring_sheet.hpp"

namespace {

class BrokenSheet : public spring_sheet::SpringSheet {
 public:
  BrokenSheet(std::string fault, std::int64_t from) : fault_(std::move(fault)), from_(from) {}

  /// Whether `f` is among the faults (--fault F1,F2).
  bool has(const std::string& f) const { return ("," + fault_ + ",").find("," + f + ",") != std::string::npos; }

  std::string model() const override { return "broken-" + fault_; }

  cosim::sdk::Markers start(const cosim::sdk::Scene& scene) override {
    cosim::sdk::Markers m = SpringSheet::start(scene);
    start_ = m.position_lb;
    time_ratio_ = scene.time_ratio;
    dx_um_ = scene.dx_m * 1e6;
    return m;
  }

  cosim::sdk::Answer step(const cosim::sdk::Interval& in) override {
    const bool on = in.step >= from_;
    if (on && has("exit-early")) std::exit(0);
    cosim::sdk::Interval run = in;
    // g dA = 2 rho (U_B - u) dA with -rho is -g dA: the marker then receives +g dA, and the
    // impulse summed is -J; negated back, J is what the motion gives.
    if (on && has("reaction-sign")) run.rho_lb = -in.rho_lb;
    // Likewise g dA with rho / 2 (2 rho): the marker receives half (twice) the reaction, and
    // the impulse summed, scaled back, is the J its motion gives.
    if (on && has("half-reaction")) run.rho_lb = 0.5 * in.rho_lb;
    if (on && has("double-reaction")) run.rho_lb = 2.0 * in.rho_lb;
    cosim::sdk::Answer a = SpringSheet::step(run);
    if (on && has("reaction-sign")) a.impulse_lb = -a.impulse_lb;
    if (on && has("half-reaction")) a.impulse_lb *= 2.0;
    if (on && has("double-reaction")) a.impulse_lb *= 0.5;
    const cosim::sdk::Matrix3X computed = a.impulse_lb;
    if (on && has("double")) a.impulse_lb *= 2.0;
    if (on && has("half")) a.impulse_lb *= 0.5;
    if (on && has("over-time-ratio")) a.impulse_lb /= double(time_ratio_);
    if (on && has("late") && previous_.cols() == computed.cols()) a.impulse_lb = previous_;
    if (on && has("frozen")) a.position_lb = start_;
    if (on && has("um")) a.position_lb *= dx_um_;
    if (on && has("mis-sized")) {
      a.position_lb.conservativeResize(3, a.position_lb.cols() - 1);
      a.impulse_lb.conservativeResize(3, a.impulse_lb.cols() - 1);
    }
    if (on && has("end-of-step")) {
      const std::vector<double> s = save();  // the positions after the last substep, then the velocities
      a.position_lb = Eigen::Map<const Eigen::Matrix3Xd>(s.data(), 3, a.position_lb.cols());
    }
    previous_ = computed;
    return a;
  }

  double energy_lb() const override {
    return has("with-energy") ? SpringSheet::energy_lb() : cosim::sdk::Solid::energy_lb();
  }

  void restore(const std::vector<double>& state) override {
    if (!has("restore-nothing")) SpringSheet::restore(state);
  }

 private:
  std::string fault_;
  std::int64_t from_ = 0;
  int time_ratio_ = 1;
  double dx_um_ = 1.0;
  cosim::sdk::Matrix3X start_, previous_;
};

}  // namespace

int main(int argc, char** argv) {
  std::string fault = "none";
  std::int64_t from = 0;
  std::vector<std::string> args;
  for (int k = 0; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--fault" && k + 1 < argc) fault = argv[++k];
    else if (a == "--from" && k + 1 < argc) from = std::atoll(argv[++k]);
    else args.push_back(a);
  }
  BrokenSheet sheet(fault, from);
  const int code = cosim::sdk::run(sheet, args);
  if (sheet.has("linger"))
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  return code;
}
