#include "service/dynamics/contacts.h"

#include <cmath>

namespace coopdyn {

const char* contact_state_name(ContactState s) {
  switch (s) {
    case ContactState::kOk: return "ok";
    case ContactState::kSlip: return "slip";
    case ContactState::kLiftOff: return "lift_off";
  }
  return "?";
}

ContactData::ContactData(const System& sys) {
  const auto& specs = sys.constraints.specs;
  for (size_t s = 0; s < specs.size(); ++s)
    if (specs[s].kind == ConstraintKind::kRolling) spec.push_back(static_cast<int>(s));
  const size_t n = spec.size();
  normal.assign(n, 0.0);
  tangential.assign(n, 0.0);
  friction_needed.assign(n, 0.0);
  utilisation.assign(n, -1.0);
  state.assign(n, ContactState::kOk);
}

void compute_contacts(const System& sys, const Workspace& ws, ContactData& cd) {
  const ConstraintSet& set = sys.constraints;
  const bool ok = ws.diag.status != Status::kError;
  cd.worst = ContactState::kOk;
  for (size_t i = 0; i < cd.spec.size(); ++i) {
    const int s = cd.spec[i];
    const double mu = set.specs[static_cast<size_t>(s)].mu;
    if (!ok) {
      cd.normal[i] = cd.tangential[i] = cd.friction_needed[i] = 0.0;
      cd.utilisation[i] = -1.0;
      cd.state[i] = ContactState::kOk;
      continue;
    }
    const int r0 = set.row_offset[static_cast<size_t>(s)];
    const double fx = ws.lambda[r0], fy = ws.lambda[r0 + 1], fz = ws.lambda[r0 + 2];
    const double ft = std::hypot(fx, fy);
    cd.normal[i] = fz;
    cd.tangential[i] = ft;
    cd.friction_needed[i] = fz > 0 ? ft / fz : -1.0;
    cd.utilisation[i] = mu > 0 && fz > 0 ? cd.friction_needed[i] / mu : -1.0;
    ContactState st = ContactState::kOk;
    if (fz < 0)
      st = ContactState::kLiftOff;
    else if (mu > 0 && ft > mu * fz)
      st = ContactState::kSlip;
    cd.state[i] = st;
    if (static_cast<int>(st) > static_cast<int>(cd.worst)) cd.worst = st;
  }
}

}  // namespace coopdyn
