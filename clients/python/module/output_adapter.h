// The decoded daemon messages (service/io: DecodedOutput, StatsFrame) as Python dicts of numpy
// arrays. The one file of the bindings that reads their fields: a change of the output codec is
// adapted here.
#pragma once

#include <pybind11/pybind11.h>

#include "service/io/codec/messages.h"

namespace coopdyn::py {

// {"utime", "tick", "sim_time", "mode", "status", "reason", "input", "input_seq", "input_utime",
//  "paused", "rows", "rank", "indeterminate", "condition", "residual", "q_names", "v_names", "q", "v",
//  "tau", "vdot" ((nq,), (nv,) arrays), "wrenches" {name: (6,) [moment; force], N*m, N},
//  "wrench_frames" {name: frame}, "sigma" {name: (6,)} (when the daemon sends it), "wrench_residual",
//  "stresses" {joint: value}, "contacts" {name: {normal, friction_needed, utilisation, state}}}
pybind11::dict output_dict(const io::DecodedOutput& o);

// Every counter and percentile of loop_stats_t by name ("lateness_us" and "compute_us": (4,) p50,
// p99, p99.9, max), "rejected_by_reason" {key: count}.
pybind11::dict stats_dict(const io::StatsFrame& s);

}  // namespace coopdyn::py
