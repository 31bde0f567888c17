// The Python binding of the solid library (sdk/include/cosim/solid.hpp), module `cosim`:
// a Python class derives from cosim.Solid and implements
//
//   model(self) -> str
//   start(self, scene) -> (positions, areas)       numpy (N, 3) in dx and (N,) in dx^2
//   step(self, step, rho, u) -> (positions, impulses)   rho (N,), u (N, 3) -> two (N, 3)
//   stable_dt_cg_s(self) -> float                  optional (default: no limit)
//   energy_lb(self) -> float                       optional: kinetic + elastic energy in
//                                                  rho_air dx^3 c^2 (default: NaN, none)
//   save(self) -> 1-d array; restore(self, state)   optional checkpoints (default: none)
//
// and runs with sys.exit(cosim.run(MySolid())) (argv defaults to sys.argv): the library
// does the rest, as for a C++ solid. Arrays are row-major (N, 3), one row per marker; a
// ValueError raised in start() ends the run with exit code 2, an answer of the wrong shape
// with 3 (as from C++), any other exception with 1.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cosim/solid.hpp"

namespace py = pybind11;
using cosim::sdk::Answer;
using cosim::sdk::Interval;
using cosim::sdk::Markers;
using cosim::sdk::Scene;
using cosim::sdk::Sheet;
using cosim::sdk::Solid;

namespace {

using Rows = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// (N, 3) rows of a 3 x N column-major matrix (the same memory layout): a copy.
Rows rows_of(const cosim::sdk::Matrix3X& m) {
  Rows a({py::ssize_t(m.cols()), py::ssize_t(3)});
  std::copy(m.data(), m.data() + m.size(), a.mutable_data());
  return a;
}

/// A 3 x N matrix from `what`, which must be (n, 3) (n = -1: any).
cosim::sdk::Matrix3X matrix_of(const py::handle& obj, Eigen::Index n, const std::string& what) {
  const Rows a = Rows::ensure(obj);
  if (!a || a.ndim() != 2 || a.shape(1) != 3 || (n >= 0 && a.shape(0) != n))
    throw std::runtime_error(what + ": expected a float array of shape (" + (n >= 0 ? std::to_string(n) : "N") +
                             ", 3)");
  return Eigen::Map<const Eigen::Matrix3Xd>(a.data(), 3, Eigen::Index(a.shape(0)));
}

cosim::sdk::Vector vector_of(const py::handle& obj, Eigen::Index n, const std::string& what) {
  const py::array_t<double, py::array::c_style | py::array::forcecast> a =
      py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || a.ndim() != 1 || a.shape(0) != n)
    throw std::runtime_error(what + ": expected a float array of shape (" + std::to_string(n) + ",)");
  return Eigen::Map<const Eigen::VectorXd>(a.data(), n);
}

std::pair<py::object, py::object> pair_of(const py::object& r, const std::string& what) {
  if (!py::isinstance<py::tuple>(r) || py::len(r) != 2)
    throw std::runtime_error(what + ": expected a tuple of two numpy arrays");
  const py::tuple t = r.cast<py::tuple>();
  return {t[0], t[1]};
}

/// The trampoline: a Python subclass's methods behind the C++ interface.
class PySolid : public Solid {
 public:
  std::string model() const override { PYBIND11_OVERRIDE_PURE(std::string, Solid, model, ); }

  Markers start(const Scene& scene) override {
    py::gil_scoped_acquire gil;
    const py::function f = py::get_override(static_cast<const Solid*>(this), "start");
    if (!f) throw std::logic_error("cosim.Solid.start is not implemented");
    py::object r;
    try {
      r = f(py::cast(scene, py::return_value_policy::reference));
    } catch (py::error_already_set& e) {
      if (e.matches(PyExc_ValueError)) throw std::invalid_argument(e.what());
      throw;
    }
    const auto [x, a] = pair_of(r, "start()");
    Markers m;
    m.position_lb = matrix_of(x, -1, "start(): positions");
    m.area_lb = vector_of(a, m.position_lb.cols(), "start(): areas");
    n_ = m.position_lb.cols();
    return m;
  }

  Answer step(const Interval& in) override {
    py::gil_scoped_acquire gil;
    const py::function f = py::get_override(static_cast<const Solid*>(this), "step");
    if (!f) throw std::logic_error("cosim.Solid.step is not implemented");
    py::array_t<double> rho(py::ssize_t(in.rho_lb.size()), in.rho_lb.data());
    const py::object r = f(in.step, rho, rows_of(in.velocity_lb));
    const auto [x, j] = pair_of(r, "step()");
    // An array of the wrong shape is a mis-sized answer (exit code 3, as from C++).
    const auto sized = [&](const py::object& o, const std::string& what) {
      try {
        return matrix_of(o, n_, what);
      } catch (const std::runtime_error& e) {
        throw std::length_error(e.what());
      }
    };
    Answer a;
    a.position_lb = sized(x, "step(): positions");
    a.impulse_lb = sized(j, "step(): impulses");
    return a;
  }

  double stable_dt_cg_s() const override { PYBIND11_OVERRIDE(double, Solid, stable_dt_cg_s, ); }
  double energy_lb() const override { PYBIND11_OVERRIDE(double, Solid, energy_lb, ); }
  std::vector<double> save() const override { PYBIND11_OVERRIDE(std::vector<double>, Solid, save, ); }
  void restore(const std::vector<double>& state) override {
    try {
      PYBIND11_OVERRIDE(void, Solid, restore, state);
    } catch (py::error_already_set& e) {
      if (e.matches(PyExc_ValueError)) throw std::invalid_argument(e.what());
      throw;
    }
  }

 private:
  Eigen::Index n_ = 0;
};

}  // namespace

PYBIND11_MODULE(cosim, m) {
  m.doc() = "The cosim solid library: a solid model in Python coupled to the cosim fluid (protocol/README.md)";

  py::class_<Sheet>(m, "Sheet", "One [[sheet]] of the scene, flat, in lattice units")
      .def_readonly("nx", &Sheet::nx)
      .def_readonly("ny", &Sheet::ny)
      .def_readonly("clamped_rows", &Sheet::clamped_rows)
      .def_readonly("spacing_w_lb", &Sheet::spacing_w_lb)
      .def_readonly("spacing_h_lb", &Sheet::spacing_h_lb)
      .def_property_readonly("positions", [](const Sheet& s) { return rows_of(s.position_lb); })
      .def_property_readonly("areas", [](const Sheet& s) { return py::array_t<double>(s.area_lb.size(), s.area_lb.data()); });

  py::class_<Scene>(m, "Scene", "What the library read from the scene file and the command line")
      .def_readonly("path", &Scene::path)
      .def_readonly("name", &Scene::name)
      .def_readonly("output_dir", &Scene::output_dir)
      .def_readonly("time_ratio", &Scene::time_ratio)
      .def_readonly("dx_m", &Scene::dx_m)
      .def_readonly("dt_lb_s", &Scene::dt_lb_s)
      .def_readonly("dt_cg_s", &Scene::dt_cg_s)
      .def_readonly("air_density_kg_m3", &Scene::air_density_kg_m3)
      .def_readonly("sound_speed_m_s", &Scene::sound_speed_m_s)
      .def_readonly("sheets", &Scene::sheets)
      .def_property_readonly("positions", [](const Scene& s) { return rows_of(s.position_lb); })
      .def_property_readonly("areas", [](const Scene& s) { return py::array_t<double>(s.area_lb.size(), s.area_lb.data()); })
      .def("param", &Scene::param, py::arg("name"), py::arg("default"),
           "The value of --NAME VALUE given after the scene, else default");

  py::class_<Solid, PySolid>(m, "Solid", "Derive from it: model(), start(scene), step(step, rho, u)")
      .def(py::init<>())
      .def("stable_dt_cg_s", &Solid::stable_dt_cg_s)
      .def("energy_lb", &Solid::energy_lb)
      .def("save", &Solid::save)
      .def("restore", &Solid::restore);

  m.def(
      "run",
      [](Solid& solid, py::object argv) {
        std::vector<std::string> args;
        if (argv.is_none()) argv = py::module_::import("sys").attr("argv");
        for (const py::handle a : argv) args.push_back(py::str(a));
        return cosim::sdk::run(solid, args);
      },
      py::arg("solid"), py::arg("argv") = py::none(),
      "Runs the solid as the solid peer of a coupled run (argv: sys.argv by default); returns the exit code");

  m.def(
      "time_steps",
      [](Solid& solid, const Scene& scene, int steps) { return cosim::sdk::time_steps(solid, scene, steps); },
      py::arg("solid"), py::arg("scene"), py::arg("steps"),
      "Seconds per LB step of solid.step() in a uniform stream, without a fluid (benchmarks)");
  m.def("synthetic_scene", &cosim::sdk::synthetic_scene, py::arg("nx"), py::arg("ny"), py::arg("time_ratio"),
        "A scene of one flat nx x ny sheet (spacing 1 dx, one clamped row) for time_steps()");
}
