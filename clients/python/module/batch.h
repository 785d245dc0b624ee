// Scene.evaluate_batch: N states evaluated in C++ with the GIL released, stacked into arrays.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "clients/python/module/scene.h"

namespace coopdyn::py {

// Q (N, nq), V (N, nv), TAU (N, nv): each None for the scene's q0, v0, zero torque in every row (one
// of them gives N). progress: an optional int64 numpy array whose first element is set to the
// number of states done as the batch goes (another Python thread may read it). Returns {"vdot",
// "wrenches" {name: (N, 6)} (views of "wrench_stack" (N, wrenches, 6)), "sigma" {name: (N, 6)} (declared
// noise), "stresses" (N, k), "status",
// "reason" (N,) str, "rank", "condition", "residual" (N,)}: row r is Scene.evaluate of row r.
pybind11::dict evaluate_batch(const Scene& s, pybind11::handle Q, pybind11::handle V, pybind11::handle TAU,
                              pybind11::handle progress);

// For bench/: seconds per state of evaluate_into over the states of a batch, repeated `repeat`
// times in C++ (what Scene.evaluate costs without Python).
double time_evaluate(const Scene& s, pybind11::handle Q, pybind11::handle V, pybind11::handle TAU, int repeat);

}  // namespace coopdyn::py
