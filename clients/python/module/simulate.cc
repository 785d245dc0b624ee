#include "clients/python/module/simulate.h"

#include <pybind11/numpy.h>

#include <cmath>
#include <optional>
#include <vector>

#include "clients/python/module/inputs.h"
#include "service/dynamics/integrators.h"

namespace coopdyn::py {

namespace pyb = pybind11;
using namespace pybind11::literals;

namespace {

// The rows written so far, one flat vector per quantity.
struct Rows {
  std::vector<double> t, q, v, tau, vdot, W, sigma, stress;
  std::vector<std::int8_t> status, reason;
  long n = 0;
};

pyb::array_t<double> stacked(const std::vector<double>& x, long n, long cols) {
  pyb::array_t<double> a({n, cols});
  std::copy(x.begin(), x.end(), a.mutable_data());
  return a;
}

pyb::array words(const std::vector<std::int8_t>& codes, bool status) {
  pyb::list w;
  for (std::int8_t c : codes)
    w.append(pyb::str(status ? status_name(static_cast<Status>(c)) : reason_key(static_cast<Reason>(c))));
  return pyb::module_::import("numpy").attr("array")(w, "dtype"_a = "str");
}

pyb::dict to_dict(const Scene& s, const Rows& r, const Diagnostics& last) {
  const System& sys = s.sys();
  const SceneNames& nm = *s.names();
  const long nq = sys.model.nq(), nv = sys.model.nv(), nw = static_cast<long>(nm.wrench.size());
  pyb::dict out, wrenches, sigma;
  out["t"] = pyb::array_t<double>(static_cast<pyb::ssize_t>(r.n), r.t.data());
  out["q"] = stacked(r.q, r.n, nq);
  out["v"] = stacked(r.v, r.n, nv);
  out["tau"] = stacked(r.tau, r.n, nv);
  out["vdot"] = stacked(r.vdot, r.n, nv);
  for (long k = 0; k < nw; ++k) {
    pyb::array_t<double> a({r.n, 6L}), b({r.n, 6L});
    for (long i = 0; i < r.n; ++i)
      for (int c = 0; c < 6; ++c) {
        a.mutable_at(i, c) = r.W[static_cast<size_t>((i * nw + k) * 6 + c)];
        if (!r.sigma.empty()) b.mutable_at(i, c) = r.sigma[static_cast<size_t>((i * nw + k) * 6 + c)];
      }
    wrenches[pyb::str(nm.wrench[k])] = a;
    if (!r.sigma.empty()) sigma[pyb::str(nm.wrench[k])] = b;
  }
  out["wrenches"] = wrenches;
  out["sigma"] = sigma;
  out["stresses"] = stacked(r.stress, r.n, static_cast<long>(nm.stress.size()));
  out["status"] = words(r.status, true);
  out["reason"] = words(r.reason, false);
  out["stopped"] = last.status == Status::kError ? pyb::object(pyb::str(reason_text(last.reason))) : pyb::none();
  return out;
}

}  // namespace

pyb::dict simulate(Scene& s, double duration, double dt, pyb::handle torque, bool hold, const std::string& integrator,
                   long every) {
  const System& sys = s.sys();
  const SceneNames& nm = *s.names();
  if (!(duration >= 0) || !std::isfinite(duration)) throw pyb::value_error("duration: must be finite and >= 0 (s)");
  if (!(dt > 0) || !std::isfinite(dt)) throw pyb::value_error("dt: must be finite and > 0 (s)");
  if (every < 1) throw pyb::value_error("every: must be >= 1");
  Integrator integ;
  if (!parse_integrator(integrator, &integ))
    throw pyb::value_error("integrator: unknown '" + integrator + "' (semi_implicit_euler, rk4, implicit_euler)");
  const int nv = sys.model.nv();
  const bool call = PyCallable_Check(torque.ptr()) != 0;
  Eigen::VectorXd tau_const = Eigen::VectorXd::Zero(nv);
  if (!call) read_vector(torque, "torque", nm.v, "v_names", tau_const);
  std::optional<HoldWorkspace> hw;
  if (hold) hw.emplace(sys, default_actuated(sys));

  Stepper st(sys);
  WrenchData wd(sys);
  WrenchSigmaData sd(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau(nv), th(nv), q_prev(q), v_prev(v);
  Rows r;
  const long steps = std::lround(duration / dt);
  Diagnostics last;
  std::optional<pyb::gil_scoped_release> nogil;
  if (!call) nogil.emplace();
  for (long i = 0; i <= steps; ++i) {
    const double t = i * dt;
    if (call) {
      tau.setZero();
      const pyb::object x = pyb::reinterpret_borrow<pyb::object>(torque)(t, pyb::array_t<double>(q.size(), q.data()),
                                                                         pyb::array_t<double>(v.size(), v.data()));
      read_vector(x, ("torque(t=" + std::to_string(t) + ")").c_str(), nm.v, "v_names", tau);
    } else {
      tau = tau_const;
    }
    if (hw && holding_torque(sys, *hw, q, v, th)) {
      clamp_to_torque_limits(sys, *hw, th);
      tau += th;
    }
    q_prev = q;
    v_prev = v;
    const Diagnostics& d = i < steps ? step(sys, st, integ, dt, tau, q, v) : evaluate(sys, st.ws, q, v, tau);
    last = d;
    if (i % every == 0 || d.status == Status::kError) {
      compute_wrenches(sys, st.ws, wd);
      if (sd.declared) compute_wrench_sigma(sys, st.ws, sd);
      r.t.push_back(t);
      r.q.insert(r.q.end(), q_prev.data(), q_prev.data() + q_prev.size());
      r.v.insert(r.v.end(), v_prev.data(), v_prev.data() + nv);
      r.tau.insert(r.tau.end(), tau.data(), tau.data() + nv);
      r.vdot.insert(r.vdot.end(), st.ws.vdot.data(), st.ws.vdot.data() + nv);
      for (size_t k = 0; k < wd.W.size(); ++k) {
        r.W.insert(r.W.end(), wd.W[k].data(), wd.W[k].data() + 6);
        if (sd.declared) r.sigma.insert(r.sigma.end(), sd.sigma[k].data(), sd.sigma[k].data() + 6);
      }
      r.stress.insert(r.stress.end(), st.ws.stress.data(), st.ws.stress.data() + st.ws.stress.size());
      r.status.push_back(static_cast<std::int8_t>(d.status));
      r.reason.push_back(static_cast<std::int8_t>(d.reason));
      ++r.n;
    }
    if (d.status == Status::kError) break;
  }
  nogil.reset();
  return to_dict(s, r, last);
}

}  // namespace coopdyn::py
