// The sigma tests' common case: a shipped scene with every joint reaction reported and noise declared
// on every joint, evaluated at the reference's test state, the fast path's estimate-mode sigma
// computed there and the reference's (wrench_sigma_reference.h) beside it, at the steps in force.
//   SigmaCase c(noisy_scene("two_puma_load"));
//   ASSERT_TRUE(c.evaluated && c.fast.valid);
//   c.compute_reference();  // then compare c.fast with c.ref over columns [0, na), [na, na + nq), ...
#pragma once

#include <string>
#include <utility>

#include "service/dynamics/sigma/wrench_sigma.h"
#include "tests/dynamics/sigma/wrench_sigma_reference.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {

// The noise of every sigma test: torque 0.2 N m, position 1e-3 rad or m, velocity 1e-2 rad/s or m/s.
inline const char* const kSigmaNoise = "noise: {tau: 0.2, q: 1e-3, v: 1e-2}\n";

// name's scene with `reactions: all` and kSigmaNoise; `extra` (top-level keys, one line each) is
// appended, replacing the scene's line of its first key if it has one (a ground with rolling
// resistance instead of the scene's).
inline System noisy_scene(const std::string& name, const std::string& extra = "", const SceneOverrides& ov = {}) {
  std::string t = without_reactions(scene_text(name));
  if (const auto colon = extra.find(':'); colon != std::string::npos) {
    const auto p = t.find("\n" + extra.substr(0, colon) + ":");
    if (p != std::string::npos) t.erase(p, t.find('\n', p + 1) - p);
  }
  return load_scene_string(t + "\nreactions: all\n" + kSigmaNoise + extra, scene_path(name), ov);
}

// sys evaluated at (q0, v, tau) of reference::random_v_tau(seed 3), with the fast path's
// estimate-mode sigma there (torque, position and velocity columns: na + nq + nv of them).
struct SigmaCase {
  explicit SigmaCase(System system) : sys(std::move(system)), ws(sys), fast(sys), ref(sys) {
    reference::random_v_tau(sys, 3, v, tau);
    evaluated = evaluate(sys, ws, sys.q0, v, tau).status != Status::kError;
    if (!evaluated) return;
    compute_wrench_sigma(sys, ws, fast, sys.q0, v, tau);
    na = static_cast<int>(fast.dofs.size());
    nv = static_cast<int>(fast.v_dofs.size());
    nq = fast.ncols - na - nv;
  }
  SigmaCase(const SigmaCase&) = delete;  // ws, fast and ref are sized from this sys
  SigmaCase& operator=(const SigmaCase&) = delete;
  // the reference's estimate-mode sigma at the same state, with the steps in force (ScopedStep)
  void compute_reference() { reference::compute_wrench_sigma(sys, ws, ref, sys.q0, v, tau); }

  const System sys;
  Workspace ws;
  WrenchSigmaData fast, ref;
  Eigen::VectorXd v, tau;
  bool evaluated = false;
  int na = 0, nq = 0, nv = 0;  // torque, position and velocity columns
};

}  // namespace coopdyn::testing
