// Scene.simulate: the fixed-step run of `coopdyn sim` (one row per written step: the state at the
// step's start, the torque applied over it, its accelerations, wrenches, stresses and status).
#pragma once

#include <pybind11/pybind11.h>

#include <string>

#include "clients/python/module/scene.h"

namespace coopdyn::py {

// torque: None (zero), an array or dict (constant), or a callable torque(t, q, v) -> array or dict
// called at every step's start. hold: the holding torques at the step's start state added, as
// `coopdyn sim --hold`. every: write every N-th step. Stops at a step that fails (its row is the
// last; "stopped" then says why). The GIL is released unless torque is a callable.
pybind11::dict simulate(Scene& s, double duration, double dt, pybind11::handle torque, bool hold,
                        const std::string& integrator, long every);

}  // namespace coopdyn::py
