// The Python module coopdyn._core (imported by the package coopdyn): load_scene, Scene, Evaluation,
// SceneError, and the live Client (client.cc). Conventions: wrenches [moment; force] in each
// output's report frame (N*m, N), poses 4x4 in the world (m), Jacobians 6 x nv [angular; linear]
// in world axes at the frame's origin, arrays in the order of the scene's names.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <filesystem>
#include <string>

#include "clients/python/module/batch.h"
#include "clients/python/module/inputs.h"
#include "clients/python/module/scene.h"
#include "clients/python/module/simulate.h"
#include "service/scene/scene.h"

namespace coopdyn::py {

namespace pyb = pybind11;
using namespace pybind11::literals;

void bind_client(pyb::module_& m);  // client.cc

namespace {

// An evaluation's results: the arrays are made on access, from the doubles copied out of the
// evaluation (later evaluations do not change them).
struct Evaluation {
  EvalResult r;
  std::shared_ptr<const SceneNames> names;
};

Eigen::Matrix4d pose(const Transform& X) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = X.R;
  T.topRightCorner<3, 1>() = X.p;
  return T;
}

pyb::array_t<double> six(const Vec6& w) { return pyb::array_t<double>(6, w.data()); }

pyb::dict by_name(const std::vector<std::string>& names, const std::vector<Vec6>& x) {
  pyb::dict d;
  for (size_t k = 0; k < x.size(); ++k) d[pyb::str(names[k])] = six(x[k]);
  return d;
}

pyb::dict diagnostics(const Diagnostics& d) {
  return pyb::dict("rows"_a = d.rows, "rank"_a = d.rank, "indeterminate"_a = d.indeterminate,
                   "condition"_a = d.condition, "residual"_a = d.residual, "status"_a = status_name(d.status),
                   "reason"_a = reason_key(d.reason), "reason_text"_a = reason_text(d.reason));
}

bool looks_like_path(const std::string& s) {
  if (s.find('\n') != std::string::npos) return false;
  std::error_code ec;
  if (std::filesystem::is_regular_file(s, ec)) return true;
  const auto ends = [&](const char* e) {
    const std::string x(e);
    return s.size() >= x.size() && s.compare(s.size() - x.size(), x.size(), x) == 0;
  };
  return ends(".yaml") || ends(".yml");
}

Scene load(const pyb::object& source, const std::optional<std::string>& formulation) {
  SceneOverrides ov;
  if (formulation) {
    Formulation f;
    if (!parse_formulation(*formulation, &f))
      throw pyb::value_error("formulation: unknown '" + *formulation +
                             "' (mobile_platform, classic, pseudo_joint, svd)");
    ov.formulation = f;
  }
  const std::string s = pyb::str(pyb::module_::import("os").attr("fspath")(source));
  const bool path = !pyb::isinstance<pyb::str>(source) || looks_like_path(s);
  System sys;
  {
    pyb::gil_scoped_release nogil;
    sys = path ? load_scene(s, ov) : load_scene_string(s, "<string>", ov);
  }
  return Scene(std::move(sys));
}

void bind_evaluation(pyb::module_& m) {
  pyb::class_<Evaluation>(m, "Evaluation",
                          "The result of Scene.evaluate (copied: later evaluations leave it as it is).")
      .def_property_readonly(
          "vdot", [](const Evaluation& e) { return pyb::array_t<double>(e.r.vdot.size(), e.r.vdot.data()); },
          "(nv,) accelerations in the order of Scene.v_names (rad/s^2 or m/s^2)")
      .def_property_readonly(
          "status", [](const Evaluation& e) { return status_name(e.r.diag.status); },
          "'ok', 'indeterminate' or 'error'")
      .def_property_readonly(
          "reason", [](const Evaluation& e) { return reason_key(e.r.diag.reason); },
          "why the status is not plain ok ('none', 'nonfinite_input', ...)")
      .def_property_readonly(
          "wrenches", [](const Evaluation& e) { return by_name(e.names->wrench, e.r.W); },
          "name -> (6,) [moment; force] in the output's report frame (N*m, N), as `coopdyn eval`")
      .def_property_readonly(
          "wrench_frames",
          [](const Evaluation& e) {
            pyb::dict d;
            for (size_t k = 0; k < e.r.X_WF.size(); ++k)
              d[pyb::str(e.names->wrench[k])] = pyb::cast(Eigen::Matrix4d(pose(e.r.X_WF[k])));
            return d;
          },
          "name -> 4x4 pose in the world of the frame each wrench is taken at and expressed in")
      .def_property_readonly(
          "sigma", [](const Evaluation& e) { return by_name(e.names->wrench, e.r.sigma); },
          "name -> (6,) standard deviation of each wrench component from the scene's noise: (empty "
          "without noise: or after a failed evaluation)")
      .def_property_readonly(
          "stresses",
          [](const Evaluation& e) {
            pyb::dict d;
            for (size_t k = 0; k < e.names->stress.size(); ++k)
              d[pyb::str(e.names->stress[k])] = e.r.stress[static_cast<Eigen::Index>(k)];
            return d;
          },
          "joint -> locking force of each pseudo-joint, then each coupling's force (N*m or N)")
      .def_property_readonly(
          "diagnostics", [](const Evaluation& e) { return diagnostics(e.r.diag); },
          "rows, rank, indeterminate, condition, residual, status, reason, reason_text")
      .def("__repr__", [](const Evaluation& e) {
        return std::string("<coopdyn.Evaluation status=") + status_name(e.r.diag.status) +
               " wrenches=" + std::to_string(e.r.W.size()) + ">";
      });
}

void bind_scene(pyb::module_& m) {
  pyb::class_<Scene>(m, "Scene",
                     "A loaded scene (coopdyn.load_scene). State arguments: arrays in the order of "
                     "q_names / v_names, or dicts by name (left out: q0, v0, zero torque).")
      .def_property_readonly("name", [](const Scene& s) { return s.sys().name; })
      .def_property_readonly("formulation",
                             [](const Scene& s) { return formulation_name(s.sys().options.formulation); })
      .def_property_readonly("q_names", [](const Scene& s) { return s.names()->q; })
      .def_property_readonly("v_names", [](const Scene& s) { return s.names()->v; })
      .def_property_readonly("wrench_names", [](const Scene& s) { return s.names()->wrench; })
      .def_property_readonly("frame_names", [](const Scene& s) { return s.names()->frame; })
      .def_property_readonly("stress_names", [](const Scene& s) { return s.names()->stress; })
      .def_property_readonly("q0",
                             [](const Scene& s) { return pyb::array_t<double>(s.sys().q0.size(), s.sys().q0.data()); })
      .def_property_readonly("v0",
                             [](const Scene& s) { return pyb::array_t<double>(s.sys().v0.size(), s.sys().v0.data()); })
      .def_property_readonly(
          "tau_limit",
          [](const Scene& s) { return pyb::array_t<double>(s.sys().tau_limit.size(), s.sys().tau_limit.data()); })
      .def_property_readonly("nq", [](const Scene& s) { return s.sys().model.nq(); })
      .def_property_readonly("nv", [](const Scene& s) { return s.sys().model.nv(); })
      .def_property_readonly("warnings", [](const Scene& s) { return s.sys().warnings; })
      .def(
          "evaluate",
          [](Scene& s, pyb::handle q, pyb::handle v, pyb::handle tau, bool hold) {
            s.read_state(q, v, tau);
            return Evaluation{s.evaluate(hold), s.names()};
          },
          "q"_a = pyb::none(), "v"_a = pyb::none(), "tau"_a = pyb::none(), "hold"_a = false,
          "The constrained evaluation at (q, v, tau), as `coopdyn eval --state` (hold: plus the holding torques, "
          "as --hold).")
      .def("evaluate_batch", &evaluate_batch, "Q"_a = pyb::none(), "V"_a = pyb::none(), "TAU"_a = pyb::none(),
           "progress"_a = pyb::none(),
           "N states (rows) evaluated in C++ with the GIL released: dict of stacked arrays (vdot (N, nv), wrenches "
           "name -> (N, 6), sigma, stresses, status (N,), reason, rank, condition, residual).")
      .def("simulate", &simulate, "duration"_a, "dt"_a, "torque"_a = pyb::none(), "hold"_a = false,
           "integrator"_a = "rk4", "every"_a = 1,
           "Fixed-step run, as `coopdyn sim`: dict of arrays t, q, v, tau, vdot, wrenches, sigma, stresses, status, "
           "reason, stopped. torque: array or dict (constant) or callable torque(t, q, v).")
      .def(
          "holding_torque",
          [](Scene& s, pyb::handle q, pyb::handle v, bool clamp) {
            s.read_state(q, v, pyb::none());
            const Eigen::VectorXd th = s.holding_torque(clamp);
            return pyb::array_t<double>(th.size(), th.data());
          },
          "q"_a = pyb::none(), "v"_a = pyb::none(), "clamp"_a = true,
          "The torques that hold (q, v) at rest, clamped to the torque limits (coopdynd's safe torque `hold`); "
          "clamp=False: as solved (a joint may exceed its limit).")
      .def(
          "frame_pose",
          [](Scene& s, const std::string& name, pyb::handle q) {
            s.read_state(q, pyb::none(), pyb::none());
            return Eigen::Matrix4d(pose(s.frame_pose(name)));
          },
          "name"_a, "q"_a = pyb::none(), "4x4 pose X_WF of an operational frame in the world (m).")
      .def(
          "jacobian",
          [](Scene& s, const std::string& name, pyb::handle q) {
            s.read_state(q, pyb::none(), pyb::none());
            return s.jacobian(name);
          },
          "name"_a, "q"_a = pyb::none(),
          "6 x nv Jacobian of the frame: [angular; linear] velocity of its origin in world axes per unit v.")
      .def(
          "mass_matrix",
          [](Scene& s, pyb::handle q) {
            s.read_state(q, pyb::none(), pyb::none());
            return s.mass_matrix();
          },
          "q"_a = pyb::none(), "nv x nv joint-space inertia M(q) (armature included).")
      .def("_time_evaluate", &time_evaluate, "Q"_a, "V"_a, "TAU"_a, "repeat"_a = 1,
           "seconds per state of the C++ evaluation alone (bench/)")
      .def("__repr__", [](const Scene& s) {
        return "<coopdyn.Scene '" + s.sys().name + "' nq=" + std::to_string(s.sys().model.nq()) +
               " nv=" + std::to_string(s.sys().model.nv()) + ">";
      });
}

}  // namespace

}  // namespace coopdyn::py

PYBIND11_MODULE(_core, m) {
  namespace pyb = pybind11;
  using namespace pybind11::literals;
  m.doc() = "coopdyn's dynamics from Python (the package coopdyn re-exports these names)";
  static pyb::exception<coopdyn::SceneError> scene_error(m, "SceneError", PyExc_ValueError);
  pyb::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const coopdyn::SceneError& e) {
      scene_error(e.what());
    }
  });
  coopdyn::py::bind_evaluation(m);
  coopdyn::py::bind_scene(m);
  coopdyn::py::bind_client(m);
  m.def("load_scene", &coopdyn::py::load, "source"_a, "formulation"_a = pyb::none(),
        "A scene from a file path or from YAML text. A broken scene raises SceneError 'file:line:col: reason', "
        "the message `coopdyn` prints.");
}
