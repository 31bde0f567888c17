// A deliberately broken solid on the solid library for the conformance kit's tests
// (tests/test_conformance.cpp): the spring sheet of examples/spring_sheet/spring_sheet.hpp
// with one planted defect chosen by --fault, from LB step --from on (default: every step):
//   none             correct (the example itself)
//   double           J x 2
//   half             J x 1/2
//   over-time-ratio  J / A_T once more
//   late             J of the previous LB step (one exchange late; the first step its own)
//   frozen           X_l the start positions while J follows the motion
//   end-of-step      X_l the positions at the interval's end, not the substeps' mean
//   reaction-sign    the markers receive +g dA instead of -g dA (J = g dA as it should be)
//   restore-nothing  restore() keeps the state it has
//   broken_sdk_solid SCENE --fault F [--from STEP] [the library's command line]
#include <cstdlib>
#include <string>
#include <vector>

#include "spring_sheet.hpp"

namespace {

class BrokenSheet : public spring_sheet::SpringSheet {
 public:
  BrokenSheet(std::string fault, std::int64_t from) : fault_(std::move(fault)), from_(from) {}

  std::string model() const override { return "broken-" + fault_; }

  cosim::sdk::Markers start(const cosim::sdk::Scene& scene) override {
    cosim::sdk::Markers m = SpringSheet::start(scene);
    start_ = m.position_lb;
    time_ratio_ = scene.time_ratio;
    return m;
  }

  cosim::sdk::Answer step(const cosim::sdk::Interval& in) override {
    const bool on = in.step >= from_;
    cosim::sdk::Interval run = in;
    // g dA = 2 rho (U_B - u) dA with -rho is -g dA: the marker then receives +g dA, and the
    // impulse summed is -J; negated back, J is what the motion gives.
    if (on && fault_ == "reaction-sign") run.rho_lb = -in.rho_lb;
    cosim::sdk::Answer a = SpringSheet::step(run);
    if (on && fault_ == "reaction-sign") a.impulse_lb = -a.impulse_lb;
    const cosim::sdk::Matrix3X computed = a.impulse_lb;
    if (on && fault_ == "double") a.impulse_lb *= 2.0;
    if (on && fault_ == "half") a.impulse_lb *= 0.5;
    if (on && fault_ == "over-time-ratio") a.impulse_lb /= double(time_ratio_);
    if (on && fault_ == "late" && previous_.cols() == computed.cols()) a.impulse_lb = previous_;
    if (on && fault_ == "frozen") a.position_lb = start_;
    if (on && fault_ == "end-of-step") {
      const std::vector<double> s = save();  // the positions after the last substep, then the velocities
      a.position_lb = Eigen::Map<const Eigen::Matrix3Xd>(s.data(), 3, a.position_lb.cols());
    }
    previous_ = computed;
    return a;
  }

  void restore(const std::vector<double>& state) override {
    if (fault_ != "restore-nothing") SpringSheet::restore(state);
  }

 private:
  std::string fault_;
  std::int64_t from_ = 0;
  int time_ratio_ = 1;
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
  return cosim::sdk::run(sheet, args);
}
