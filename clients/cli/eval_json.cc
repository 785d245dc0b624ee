#include "clients/cli/eval_json.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "clients/cli/text.h"
#include "service/algorithms/kinematics.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/free_directions.h"
#include "service/dynamics/friction_bound.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/dynamics/joint_limits.h"
#include "service/dynamics/wrenches.h"

namespace coopdyn::cli {

namespace {
void num(std::FILE* f, double x) {
  if (std::isfinite(x)) std::fprintf(f, "%.17g", x);  // round-trips
  else std::fprintf(f, "null");
}
void list(std::FILE* f, const double* x, int n) {
  std::fprintf(f, "[");
  for (int i = 0; i < n; ++i) {
    if (i) std::fprintf(f, ", ");
    num(f, x[i]);
  }
  std::fprintf(f, "]");
}
void names(std::FILE* f, const std::vector<std::string>& v) {
  std::fprintf(f, "[");
  for (size_t i = 0; i < v.size(); ++i) std::fprintf(f, "%s\"%s\"", i ? ", " : "", v[i].c_str());
  std::fprintf(f, "]");
}

// The names of the axes set in a 6-bit mask (bit c: wx, wy, wz, vx, vy, vz), as a JSON list.
void axes(std::FILE* f, unsigned mask) {
  static const char* ax[6] = {"wx", "wy", "wz", "vx", "vy", "vz"};
  std::fprintf(f, "[");
  bool first = true;
  for (int c = 0; c < 6; ++c)
    if (mask & (1u << c)) {
      std::fprintf(f, "%s\"%s\"", first ? "" : ", ", ax[c]);
      first = false;
    }
  std::fprintf(f, "]");
}

// scene, formulation, the coordinates' names, and q, v, tau, vdot
void write_state(std::FILE* f, const System& sys, const Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                 const Eigen::VectorXd& tau) {
  std::fprintf(f, "{\n  \"scene\": \"%s\",\n  \"formulation\": \"%s\",\n", sys.name.c_str(),
               formulation_name(sys.options.formulation));
  std::fprintf(f, "  \"coordinates\": {\"q\": ");
  names(f, sys.model.q_names);
  std::fprintf(f, ", \"v\": ");
  names(f, sys.model.v_names);
  std::fprintf(f, "},\n  \"q\": ");
  list(f, q.data(), static_cast<int>(q.size()));
  std::fprintf(f, ",\n  \"v\": ");
  list(f, v.data(), static_cast<int>(v.size()));
  std::fprintf(f, ",\n  \"tau\": ");
  list(f, tau.data(), static_cast<int>(tau.size()));
  std::fprintf(f, ",\n  \"vdot\": ");
  list(f, ws.vdot.data(), static_cast<int>(ws.vdot.size()));
}

// wheel: the ground's force on the wheel at the contact point, in the contact frame C
void write_contact_frame(std::FILE* f, const Model& model, const Workspace& ws, const ConstraintSpec& c) {
  const Transform X_WC = rolling_contact_frame(model, ws.data, c);
  std::fprintf(f, "\"on\": \"%s\", \"contact\": {\"p_W\": ", model.bodies[c.body].name.c_str());
  list(f, X_WC.p.data(), 3);
  const Vec3 xc = X_WC.R.col(0), yc = X_WC.R.col(1), zc = X_WC.R.col(2);
  std::fprintf(f, ", \"x_W\": ");
  list(f, xc.data(), 3);
  std::fprintf(f, ", \"y_W\": ");
  list(f, yc.data(), 3);
  std::fprintf(f, ", \"z_W\": ");
  list(f, zc.data(), 3);
  std::fprintf(f, "}, ");
}

// the report frame's pose in the world: origin, then the rotation matrix by rows
void write_frame_pose(std::FILE* f, const System& sys, const Workspace& ws, int k) {
  const Transform X = wrench_frame_pose(sys, ws.data, k);
  std::fprintf(f, "\"frame_W\": {\"p\": ");
  list(f, X.p.data(), 3);
  std::fprintf(f, ", \"R\": [");
  for (int r = 0; r < 3; ++r) {
    const Vec3 row = X.R.row(r).transpose();
    std::fprintf(f, "%s", r ? ", " : "");
    list(f, row.data(), 3);
  }
  std::fprintf(f, "]}, ");
}

// every reported wrench: what it is, where, its value, which axes it carries or constrains
// with declared noise (sd.valid) each wrench's sigma: standard deviations [moment; force] in its
// frame (wrench_sigma.h); without, no "sigma" key. With Coulomb friction joints at rest, its
// "bound": the largest departure [moment; force] their unknown friction allows (friction_bound.h)
void write_wrenches(std::FILE* f, const System& sys, const Workspace& ws, const WrenchData& wd,
                    const WrenchSigmaData& sd, const FrictionBoundData& fb) {
  std::fprintf(f, ",\n  \"wrenches\": [");
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    const WrenchOutput& o = sys.wrenches.outputs[k];
    std::fprintf(f, "%s\n    {\"name\": \"%s\", \"kind\": \"%s\", \"frame\": \"%s\", \"by\": \"%s\", ", k ? "," : "",
                 o.name.c_str(), wrench_kind_name(o.kind), o.frame.c_str(), o.by.c_str());
    if (o.spec >= 0 && sys.constraints.specs[o.spec].kind == ConstraintKind::kRolling)
      write_contact_frame(f, sys.model, ws, sys.constraints.specs[o.spec]);
    write_frame_pose(f, sys, ws, static_cast<int>(k));
    std::fprintf(f, "\"moment\": ");
    list(f, wd.W[k].data(), 3);
    std::fprintf(f, ", \"force\": ");
    list(f, wd.W[k].data() + 3, 3);
    std::fprintf(f, ", \"%s\": ", o.kind == WrenchKind::kJoint || o.kind == WrenchKind::kAxle ? "carried" : "constrained");
    axes(f, o.constrained);
    std::fprintf(f, ", \"indeterminate\": ");
    axes(f, wd.indeterminate[k]);
    if (sd.valid) {
      std::fprintf(f, ", \"sigma\": ");
      list(f, sd.sigma[k].data(), 6);
    }
    if (fb.resting > 0) {
      std::fprintf(f, ", \"bound\": ");
      list(f, fb.bound[k].data(), 6);
    }
    std::fprintf(f, "}");
  }
  std::fprintf(f, "\n  ]");
}

// each free direction of the multipliers: its class, a reading, lambda along it and every
// reported wrench it moves (per unit; any multiple may be added to the wrenches above)
void write_free_directions(std::FILE* f, const System& sys, const WrenchData& wd) {
  std::fprintf(f, ",\n  \"free_directions\": [");
  for (int dir = 0; dir < wd.num_free; ++dir) {
    std::fprintf(f, "%s\n    {\"class\": \"%s\", \"reading\": %s", dir ? "," : "",
                 free_class_name(wd.free_class[static_cast<size_t>(dir)]), json_string(free_direction_reading(sys, wd, dir)).c_str());
    std::fprintf(f, ", \"lambda\": ");
    list(f, wd.free_lambda.col(dir).data(), static_cast<int>(wd.free_lambda.rows()));
    std::fprintf(f, ", \"wrenches\": [");
    bool first = true;
    for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
      const double* x = wd.free_W.col(dir).data() + 6 * k;
      double mx = 0;
      for (int c = 0; c < 6; ++c) mx = std::max(mx, std::abs(x[c]));
      if (mx <= 1e-12) continue;
      std::fprintf(f, "%s{\"name\": \"%s\", \"moment\": ", first ? "" : ", ", sys.wrenches.outputs[k].name.c_str());
      list(f, x, 3);
      std::fprintf(f, ", \"force\": ");
      list(f, x + 3, 3);
      std::fprintf(f, "}");
      first = false;
    }
    std::fprintf(f, "]}");
  }
  std::fprintf(f, "%s]", wd.num_free ? "\n  " : "");
}

// each rolling contact: what the road must supply (README "Vehicles"); -1: undefined
void write_contacts(std::FILE* f, const System& sys, const Workspace& ws) {
  ContactData cts(sys);
  compute_contacts(sys, ws, cts);
  std::fprintf(f, ",\n  \"contacts\": [");
  for (size_t i = 0; i < cts.spec.size(); ++i) {
    const ConstraintSpec& c = sys.constraints.specs[static_cast<size_t>(cts.spec[i])];
    std::fprintf(f, "%s\n    {\"name\": \"%s\", \"normal\": ", i ? "," : "", c.name.c_str());
    num(f, cts.normal[i]);
    std::fprintf(f, ", \"tangential\": ");
    num(f, cts.tangential[i]);
    std::fprintf(f, ", \"friction_needed\": ");
    num(f, cts.friction_needed[i]);
    std::fprintf(f, ", \"mu\": ");
    if (c.mu > 0) num(f, c.mu);
    else std::fprintf(f, "null");
    std::fprintf(f, ", \"utilisation\": ");
    num(f, cts.utilisation[i]);
    std::fprintf(f, ", \"state\": \"%s\"}", contact_state_name(cts.state[i]));
  }
  std::fprintf(f, "%s],\n  \"contact_status\": \"%s\"", cts.spec.empty() ? "" : "\n  ", contact_state_name(cts.worst));
}

void write_stresses(std::FILE* f, const System& sys, const Workspace& ws) {
  std::fprintf(f, ",\n  \"stresses\": [");
  const int n = num_stresses(sys);
  for (int a = 0; a < n; ++a) {
    std::fprintf(f, "%s\n    {\"joint\": \"%s\", \"value\": ", a ? "," : "", stress_name(sys, a).c_str());
    num(f, ws.stress[a]);
    std::fprintf(f, ", \"unit\": \"%s\"}", stress_unit(sys, a));
  }
  std::fprintf(f, "%s]", n == 0 ? "" : "\n  ");
}

// The joints whose limits (q, v, tau) exceed (joint_limits.h): name and kinds, in velocity order.
void write_limits(std::FILE* f, const System& sys, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                  const Eigen::VectorXd& tau) {
  LimitData ld(sys);
  check_joint_limits(sys, ld, q, v, tau);
  std::fprintf(f, ",\n  \"limits_exceeded\": [");
  int n = 0;
  for (int d : ld.dofs) {
    if (!ld.mask[d]) continue;
    std::fprintf(f, "%s\n    {\"joint\": \"%s\", \"exceeded\": [", n++ ? "," : "", sys.model.v_names[d].c_str());
    int k = 0;
    for (LimitBit b : {kLimitPosition, kLimitVelocity, kLimitEffort})
      if (ld.mask[d] & b) std::fprintf(f, "%s\"%s\"", k++ ? ", " : "", limit_word(b));
    std::fprintf(f, "]}");
  }
  std::fprintf(f, "%s]", n == 0 ? "" : "\n  ");
}

void write_diagnostics(std::FILE* f, const Diagnostics& d) {
  std::fprintf(f, ",\n  \"diagnostics\": {\"rows\": %d, \"rank\": %d, \"indeterminate\": %d, \"condition\": ", d.rows,
               d.rank, d.indeterminate);
  num(f, d.condition);
  std::fprintf(f, ", \"residual\": ");
  num(f, d.residual);
  std::fprintf(f, ", \"status\": \"%s\", \"reason\": \"%s\"}\n}\n", status_name(d.status), reason_text(d.reason));
}
}  // namespace

void write_eval_json(std::FILE* f, const System& sys, Workspace& ws, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  WrenchSigmaData sd(sys);
  compute_wrench_sigma(sys, ws, sd);
  FrictionBoundData fb(sys);
  compute_friction_bound(sys, ws, fb);
  write_state(f, sys, ws, q, v, tau);
  write_wrenches(f, sys, ws, wd, sd, fb);
  write_free_directions(f, sys, wd);
  write_contacts(f, sys, ws);
  write_stresses(f, sys, ws);
  write_limits(f, sys, q, v, tau);
  write_diagnostics(f, ws.diag);
}

int warn_contacts(std::FILE* f, const char* cmd, const System& sys, const Workspace& ws, double t) {
  ContactData cts(sys);
  compute_contacts(sys, ws, cts);
  int n = 0;
  for (size_t i = 0; i < cts.spec.size(); ++i) {
    if (cts.state[i] == ContactState::kOk) continue;
    const ConstraintSpec& c = sys.constraints.specs[static_cast<size_t>(cts.spec[i])];
    std::fprintf(f, "coopdyn %s: warning: ", cmd);
    if (std::isfinite(t)) std::fprintf(f, "t=%g: ", t);
    if (cts.state[i] == ContactState::kLiftOff)
      std::fprintf(f, "wheel '%s' lifts off (normal force %.6g N < 0: the ground would have to pull it)\n", c.name.c_str(),
                   cts.normal[i]);
    else
      std::fprintf(f, "wheel '%s' needs more friction than it has (%.6g N tangential on %.6g N normal: %.4g > mu = %g)\n",
                   c.name.c_str(), cts.tangential[i], cts.normal[i], cts.friction_needed[i], c.mu);
    ++n;
  }
  return n;
}

}  // namespace coopdyn::cli
