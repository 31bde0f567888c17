// bench_step: milliseconds per LB step of a solid's step() on the solid library, without a
// fluid (cosim::sdk::time_steps: a uniform stream, A_T = 150): the spring-network sheet of
// spring_sheet.hpp and a solid that does nothing (the library's own cost per step). The
// Python side is examples/python_sheet/bench_step.py; launch/bench-binding.sh prints both
// as the table of docs/solid-library.md.
//   bench_step [NX NY STEPS]...   (default: 4 6 200 20 20 50)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "spring_sheet.hpp"

namespace {

class NoOp : public cosim::sdk::Solid {
 public:
  std::string model() const override { return "no-op"; }
  cosim::sdk::Markers start(const cosim::sdk::Scene& s) override {
    x_ = s.position_lb;
    return {s.position_lb, s.area_lb};
  }
  cosim::sdk::Answer step(const cosim::sdk::Interval&) override { return {x_, Eigen::Matrix3Xd::Zero(3, x_.cols())}; }

 private:
  Eigen::Matrix3Xd x_;
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> args{4, 6, 200, 20, 20, 50};
  if (argc > 1) {
    args.clear();
    for (int k = 1; k < argc; ++k) args.push_back(std::atoi(argv[k]));
  }
  for (std::size_t k = 0; k + 2 < args.size(); k += 3) {
    const cosim::sdk::Scene scene = cosim::sdk::synthetic_scene(args[k], args[k + 1], 150);
    NoOp none;
    cosim::sdk::time_steps(none, scene, args[k + 2]);  // warm-up
    // The best of 5: the machine may be shared, and other processes only ever add time.
    double t_none = 1e300, t_sheet = 1e300;
    for (int r = 0; r < 5; ++r) {
      t_none = std::min(t_none, cosim::sdk::time_steps(none, scene, args[k + 2] * 10));
      spring_sheet::SpringSheet fresh;
      t_sheet = std::min(t_sheet, cosim::sdk::time_steps(fresh, scene, args[k + 2]));
    }
    std::printf("cpp %d markers: no-op %.6f ms, spring sheet %.6f ms per LB step\n", args[k] * args[k + 1],
                1e3 * t_none, 1e3 * t_sheet);
  }
  return 0;
}
