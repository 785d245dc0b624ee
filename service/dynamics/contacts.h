// What the road must supply at each rolling contact: the normal force, the friction the no-slip
// forces need, its utilisation against the contact's friction coefficient, and whether the model
// has left its range (a wheel that would slide or lift off). Read from one evaluation's
// multipliers (ws.lambda: the ground's force on the wheel in the contact frame C, [fx fy fz]).
//
// The no-slip model gives the force the road would have to supply to keep every wheel rolling;
// it does not check it can. A contact is
//   kLiftOff  when fz < 0: the ground would have to pull the wheel down (the wheel leaves it),
//   kSlip     when sqrt(fx^2 + fy^2) > mu fz: more friction than the coefficient allows,
//   kOk       otherwise (and always kOk on friction when the scene gives no mu).
// Where the tangential split is indeterminate (wheels on one rigid axle), the utilisation is that
// of the split the scene's redundancy rule chose (README "Vehicles").
// Allocation-free after construction; never throws.
#pragma once

#include <cstdint>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"

namespace coopdyn {

enum class ContactState : uint8_t { kOk = 0, kSlip = 1, kLiftOff = 2 };
const char* contact_state_name(ContactState s);  // "ok", "slip", "lift_off"

struct ContactData {
  explicit ContactData(const System& sys);
  std::vector<int> spec;                // per contact: its rolling constraint spec, in spec order
  std::vector<double> normal;           // fz, N (the ground's push on the wheel along its normal)
  std::vector<double> tangential;       // sqrt(fx^2 + fy^2), N
  std::vector<double> friction_needed;  // tangential / normal; -1 where undefined (normal <= 0)
  std::vector<double> utilisation;      // friction_needed / mu; -1 where undefined (no mu given,
                                        // or normal <= 0: then `state` says lift_off or the wheel
                                        // is unloaded). Never Inf or NaN: these go on the wire.
  std::vector<ContactState> state;
  ContactState worst = ContactState::kOk;  // kLiftOff over kSlip over kOk
};

// Fills cd from the evaluation in ws; every contact kOk with zero forces when the evaluation failed.
void compute_contacts(const System& sys, const Workspace& ws, ContactData& cd);

}  // namespace coopdyn
