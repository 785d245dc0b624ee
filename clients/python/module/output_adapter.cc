#include "clients/python/module/output_adapter.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "service/dynamics/constrained_dynamics.h"

namespace coopdyn::py {

namespace pyb = pybind11;

namespace {
pyb::array_t<double> arr(const std::vector<double>& x) { return pyb::array_t<double>(x.size(), x.data()); }
pyb::dict by_name(const std::vector<std::string>& names, const std::vector<std::array<double, 6>>& w) {
  pyb::dict d;
  for (size_t k = 0; k < names.size() && k < w.size(); ++k)
    d[pyb::str(names[k])] = pyb::array_t<double>(6, w[k].data());
  return d;
}
}  // namespace

pyb::dict output_dict(const io::DecodedOutput& o) {
  pyb::dict d;
  d["utime"] = o.utime, d["tick"] = o.tick, d["sim_time"] = o.sim_time;
  d["mode"] = io::mode_key(o.mode);
  d["status"] = status_name(static_cast<Status>(o.status));
  d["reason"] = io::reason_key(o.reason);
  d["input"] = io::input_key(o.input);
  d["input_seq"] = o.input_seq, d["input_utime"] = o.input_utime, d["paused"] = o.paused != 0;
  d["rows"] = o.rows, d["rank"] = o.rank, d["indeterminate"] = o.indeterminate;
  d["condition"] = o.condition, d["residual"] = o.residual;
  d["q_names"] = o.q_names, d["v_names"] = o.v_names;
  d["q"] = arr(o.q), d["v"] = arr(o.v), d["tau"] = arr(o.tau), d["vdot"] = arr(o.vdot);
  d["wrenches"] = by_name(o.wrench_names, o.wrench);
  pyb::dict frames;
  for (size_t k = 0; k < o.wrench_names.size() && k < o.wrench_frames.size(); ++k)
    frames[pyb::str(o.wrench_names[k])] = o.wrench_frames[k];
  d["wrench_frames"] = frames;
  d["sigma"] = o.sigma_source ? by_name(o.wrench_names, o.wrench_sigma) : pyb::dict();
  d["wrench_residual"] = by_name(o.wrench_names, o.wrench_residual);
  pyb::dict stresses;
  for (size_t k = 0; k < o.stress_names.size() && k < o.stress.size(); ++k)
    stresses[pyb::str(o.stress_names[k])] = o.stress[k];
  d["stresses"] = stresses;
  pyb::dict contacts;
  for (size_t k = 0; k < o.contact_names.size(); ++k)
    contacts[pyb::str(o.contact_names[k])] =
        pyb::dict(pyb::arg("normal") = o.contact_normal[k], pyb::arg("friction_needed") = o.contact_friction_needed[k],
                  pyb::arg("utilisation") = o.contact_utilisation[k], pyb::arg("state") = o.contact_state[k]);
  d["contacts"] = contacts;
  return d;
}

pyb::dict stats_dict(const io::StatsFrame& s) {
  pyb::dict d;
  d["utime"] = s.utime, d["tick"] = s.tick, d["period_us"] = s.period_us, d["window_ticks"] = s.window_ticks;
  d["lateness_us"] = pyb::array_t<double>(4, s.lateness_us);
  d["compute_us"] = pyb::array_t<double>(4, s.compute_us);
  d["overruns"] = s.overruns, d["skipped_periods"] = s.skipped_periods;
  d["received"] = s.received, d["accepted"] = s.accepted, d["rejected"] = s.rejected;
  d["out_of_order"] = s.out_of_order, d["expired"] = s.expired, d["numerical_errors"] = s.numerical_errors;
  d["receiver_restarts"] = s.receiver_restarts, d["inputs_dropped"] = s.inputs_dropped;
  d["missed"] = s.missed, d["inputs_filtered"] = s.inputs_filtered;
  pyb::dict by;
  for (int k = 1; k < io::kRejectKinds; ++k)
    by[pyb::str(io::reject_key(static_cast<io::Reject>(k)))] = s.rejected_by_reason[k];
  d["rejected_by_reason"] = by;
  d["closure_rejected"] = s.closure_rejected, d["inputs_malformed"] = s.inputs_malformed;
  d["controls_received"] = s.controls_received, d["controls_accepted"] = s.controls_accepted;
  d["controls_rejected"] = s.controls_rejected, d["controls_unauthenticated"] = s.controls_unauthenticated;
  d["controls_bad_mac"] = s.controls_bad_mac, d["controls_replayed"] = s.controls_replayed;
  d["outputs_dropped"] = s.outputs_dropped;
  return d;
}

}  // namespace coopdyn::py
