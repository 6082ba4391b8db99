// drops._drops._DescriptionPrior: the C++ drops::description::DescriptionPrior (a URDF or MJCF
// file as the simulator prior) for the Python class drops.DescriptionPrior (drops/description.py),
// and native_prior(), which hands it to a run of a Python task as a C++ MeanFunction (no Python
// callback per batch). Without MuJoCo (DROPS_WITH_MUJOCO off) the class is absent and
// native_prior() accepts only None.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "python_robot.hpp"

#ifdef DROPS_WITH_MUJOCO
#include "drops/description/description_prior.hpp"
#endif

namespace drops::python {

#ifdef DROPS_WITH_MUJOCO
namespace {
using description::DescriptionPrior;
using description::DescriptionPriorOptions;
}  // namespace

void bind_description(py::module_& m) {
  py::class_<DescriptionPrior>(
      m, "_DescriptionPrior",
      "drops::description::DescriptionPrior (use drops.DescriptionPrior). Its methods release the "
      "interpreter lock while MuJoCo runs and may be called from several threads.")
      .def(py::init([](const std::string& file, const std::vector<std::string>& joints,
                       const std::vector<std::string>& actuated,
                       const std::vector<std::string>& parameters, double dt, int substeps,
                       double coulomb_velocity) {
             DescriptionPriorOptions o;
             o.file = file;
             o.joints = joints;
             o.actuated = actuated;
             o.parameters = parameters;
             o.dt = dt;
             o.substeps = substeps;
             o.coulomb_velocity = coulomb_velocity;
             return std::make_unique<DescriptionPrior>(o);
           }),
           py::arg("file"), py::arg("joints"), py::arg("actuated"), py::arg("parameters"),
           py::arg("dt"), py::arg("substeps"), py::arg("coulomb_velocity"),
           py::call_guard<py::gil_scoped_release>())
      .def(
          "evaluate",
          [](const DescriptionPrior& p, const MatrixXd& X, const MatrixXd& U, const VectorXd& phi) {
            MatrixXd dX;
            {
              py::gil_scoped_release release;
              p.evaluate_batch(X, U, phi, dX);
            }
            return dX;
          },
          py::arg("x"), py::arg("u"), py::arg("phi"),
          "x (B, 2n), u (B, m), phi (P,) -> dx (B, 2n).")
      .def("check_phi", &DescriptionPrior::check_phi, py::arg("phi"))
      .def("default_phi", &DescriptionPrior::default_phi)
      .def("parameter_names", &DescriptionPrior::parameter_names)
      .def("joint_names", &DescriptionPrior::joint_names)
      .def("actuated_joint_names", &DescriptionPrior::actuated_joint_names)
      .def("body_names", &DescriptionPrior::body_names)
      .def("available_parameters", &DescriptionPrior::available_parameters)
      .def("warnings", &DescriptionPrior::warnings)
      .def("parameter_index", &DescriptionPrior::parameter_index, py::arg("name"))
      .def(
          "parameter_domain",
          [](const DescriptionPrior& p, int i) {
            const auto d = p.parameter_domain(i);
            return py::make_tuple(d.lower, d.upper, d.lower_open, d.unit, d.what);
          },
          py::arg("i"), "(lower, upper, lower_open, unit, what) of parameter i.")
      .def("check_bounds", &DescriptionPrior::check_bounds, py::arg("i"), py::arg("lower"),
           py::arg("upper"));
}

std::shared_ptr<const model::MeanFunction> native_prior(py::handle obj) {
  if (obj.is_none()) return nullptr;
  return std::shared_ptr<const model::MeanFunction>(obj.cast<const DescriptionPrior&>().clone());
}
#else
void bind_description(py::module_&) {}

std::shared_ptr<const model::MeanFunction> native_prior(py::handle obj) {
  if (!obj.is_none()) throw InvalidArgument("this drops was built without MuJoCo: no native prior");
  return nullptr;
}
#endif

}  // namespace drops::python
