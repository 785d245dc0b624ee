#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "clients/cli/common.h"
#include "service/algorithms/kinematics.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/free_directions.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

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
}  // namespace

// Only characters the shell passes as they are stay unquoted.
std::string shell_quote(const std::string& s) {
  if (s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=./:,@%") == std::string::npos &&
      !s.empty())
    return s;
  std::string o = "'";
  for (const char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (size_t i = 0; i < s.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == '"' || c == '\\') {
      o += '\\';
      o += static_cast<char>(c);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      o += buf;
    } else if (c == '/' && i > 0 && s[i - 1] == '<') {
      o += "\\/";
    } else {
      o += static_cast<char>(c);
    }
  }
  return o + "\"";
}

void write_eval_json(std::FILE* f, const System& sys, const Workspace& ws, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  const Model& model = sys.model;
  static const char* ax[6] = {"wx", "wy", "wz", "vx", "vy", "vz"};
  std::fprintf(f, "{\n  \"scene\": \"%s\",\n  \"formulation\": \"%s\",\n", sys.name.c_str(),
               formulation_name(sys.options.formulation));
  std::fprintf(f, "  \"coordinates\": {\"q\": ");
  names(f, model.q_names);
  std::fprintf(f, ", \"v\": ");
  names(f, model.v_names);
  std::fprintf(f, "},\n  \"q\": ");
  list(f, q.data(), static_cast<int>(q.size()));
  std::fprintf(f, ",\n  \"v\": ");
  list(f, v.data(), static_cast<int>(v.size()));
  std::fprintf(f, ",\n  \"tau\": ");
  list(f, tau.data(), static_cast<int>(tau.size()));
  std::fprintf(f, ",\n  \"vdot\": ");
  list(f, ws.vdot.data(), static_cast<int>(ws.vdot.size()));
  std::fprintf(f, ",\n  \"wrenches\": [");
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    const WrenchOutput& o = sys.wrenches.outputs[k];
    std::fprintf(f, "%s\n    {\"name\": \"%s\", \"kind\": \"%s\", \"frame\": \"%s\", \"by\": \"%s\", ", k ? "," : "",
                 o.name.c_str(), wrench_kind_name(o.kind), o.frame.c_str(), o.by.c_str());
    if (o.spec >= 0 && sys.constraints.specs[o.spec].kind == ConstraintKind::kRolling) {
      // wheel: the ground's force on the wheel at the contact point, in the contact frame C
      const ConstraintSpec& c = sys.constraints.specs[o.spec];
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
    {  // the report frame's pose in the world: origin, then the rotation matrix by rows
      const Transform X = wrench_frame_pose(sys, ws.data, static_cast<int>(k));
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
    std::fprintf(f, "\"moment\": ");
    list(f, wd.W[k].data(), 3);
    std::fprintf(f, ", \"force\": ");
    list(f, wd.W[k].data() + 3, 3);
    std::fprintf(f, ", \"%s\": [", o.kind == WrenchKind::kJoint || o.kind == WrenchKind::kAxle ? "carried" : "constrained");
    bool fa = true;
    for (int c = 0; c < 6; ++c)
      if (o.constrained & (1u << c)) {
        std::fprintf(f, "%s\"%s\"", fa ? "" : ", ", ax[c]);
        fa = false;
      }
    std::fprintf(f, "], \"indeterminate\": [");
    fa = true;
    for (int c = 0; c < 6; ++c)
      if (wd.indeterminate[k] & (1u << c)) {
        std::fprintf(f, "%s\"%s\"", fa ? "" : ", ", ax[c]);
        fa = false;
      }
    std::fprintf(f, "]}");
  }
  std::fprintf(f, "\n  ],\n  \"free_directions\": [");
  // each free direction of the multipliers: its class, a reading, lambda along it and every
  // reported wrench it moves (per unit; any multiple may be added to the wrenches above)
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
  std::fprintf(f, "%s],\n  \"contacts\": [", wd.num_free ? "\n  " : "");
  // each rolling contact: what the road must supply (README "Vehicles"); -1: undefined
  ContactData cts(sys);
  compute_contacts(sys, ws, cts);
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
  std::fprintf(f, "%s],\n  \"contact_status\": \"%s\",\n  \"stresses\": [", cts.spec.empty() ? "" : "\n  ",
               contact_state_name(cts.worst));
  for (size_t a = 0; a < model.pseudo_dofs.size(); ++a) {
    const int d = model.pseudo_dofs[a];
    std::fprintf(f, "%s\n    {\"joint\": \"%s\", \"value\": ", a ? "," : "", model.v_names[d].c_str());
    num(f, ws.stress[static_cast<Eigen::Index>(a)]);
    std::fprintf(f, ", \"unit\": \"%s\"}", model.bodies[model.dof_body[d]].joint.type == JointType::kPrismatic ? "N" : "N*m");
  }
  const Diagnostics& d = ws.diag;
  std::fprintf(f, "%s],\n  \"diagnostics\": {\"rows\": %d, \"rank\": %d, \"indeterminate\": %d, \"condition\": ",
               model.pseudo_dofs.empty() ? "" : "\n  ", d.rows, d.rank, d.indeterminate);
  num(f, d.condition);
  std::fprintf(f, ", \"residual\": ");
  num(f, d.residual);
  std::fprintf(f, ", \"status\": \"%s\", \"reason\": \"%s\"}\n}\n", status_name(d.status), reason_text(d.reason));
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

int load_cli_scene(const SceneArgs& a, const char* cmd, System* sys) {
  if (!a.scene) {
    std::fprintf(stderr, "coopdyn %s: --scene FILE is required\n", cmd);
    return 2;
  }
  SceneOverrides ov;
  if (a.formulation) {
    Formulation f;
    if (!parse_formulation(*a.formulation, &f)) {
      std::fprintf(stderr, "coopdyn %s: unknown formulation '%s' (mobile_platform, classic, pseudo_joint, svd)\n", cmd,
                   a.formulation->c_str());
      return 2;
    }
    ov.formulation = f;
  }
  try {
    *sys = load_scene(*a.scene, ov);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "coopdyn: %s\n", e.what());
    return 1;
  }
  for (const std::string& w : sys->warnings) std::fprintf(stderr, "coopdyn %s: warning: %s\n", cmd, w.c_str());
  return 0;
}

int load_cli_profile(const ProfileArgs& a, const char* cmd, const System& sys, TorqueProfile* prof) {
  try {
    for (const auto& spec : a.torque) prof->add(sys, spec);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "coopdyn %s: %s\n", cmd, e.what());
    return 2;
  }
  return 0;
}

int load_cli_targets(const ProfileArgs& a, const char* cmd, const System& sys, TorqueProfile* prof, std::vector<int>* locks) {
  try {
    for (const auto& spec : a.steer) prof->add(sys, spec);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "coopdyn %s: --steer: %s\n", cmd, e.what());
    return 2;
  }
  locks->clear();
  const std::vector<ConstraintSpec>& specs = sys.constraints.specs;
  for (int d : prof->dofs()) {
    int lock = -1;
    for (size_t k = 0; k < specs.size(); ++k)
      if (specs[k].kind == ConstraintKind::kLock && specs[k].dof == d) lock = static_cast<int>(k);
    if (lock < 0 || specs[static_cast<size_t>(lock)].target_limit <= 0) {
      std::fprintf(stderr, "coopdyn %s: --steer: '%s' is not a locked joint with a target_limit (a pseudo-joint whose "
                   "scene entry declares target_limit; formulation pseudo_joint has no lock rows)\n", cmd,
                   sys.model.v_names[static_cast<size_t>(d)].c_str());
      return 2;
    }
    locks->push_back(lock);
  }
  // within the limits: the profiles are piecewise linear, so their extremes are at breakpoints
  Eigen::VectorXd x(sys.model.nv());
  for (double t : prof->breakpoints()) {
    for (double tt : {t, std::nextafter(t, -HUGE_VAL)}) {
      prof->eval(tt, x);
      const std::vector<int> ds = prof->dofs();
      for (size_t i = 0; i < ds.size(); ++i) {
        const double lim = specs[static_cast<size_t>((*locks)[i])].target_limit;
        if (!(std::abs(x[ds[i]]) <= lim)) {
          std::fprintf(stderr, "coopdyn %s: --steer: '%s' reaches %g at t=%g, beyond its target_limit %g\n", cmd,
                       sys.model.v_names[static_cast<size_t>(ds[i])].c_str(), x[ds[i]], tt, lim);
          return 2;
        }
      }
    }
  }
  return 0;
}

int velocity_index(const System& sys, const std::string& name) {
  const auto& n = sys.model.v_names;
  for (size_t i = 0; i < n.size(); ++i)
    if (n[i] == name) return static_cast<int>(i);
  return -1;
}

namespace {
std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep)) out.push_back(item);
  return out;
}
double to_num(const std::string& s, const std::string& what) {
  try {
    size_t pos = 0;
    const double x = std::stod(s, &pos);
    if (pos != s.size() || !std::isfinite(x)) throw std::invalid_argument("");
    return x;
  } catch (const std::exception&) {
    throw std::runtime_error("bad number '" + s + "' in " + what);
  }
}
}  // namespace

void TorqueProfile::add(const System& sys, const std::string& spec) {
  if (spec.size() > 4 && spec.substr(spec.size() - 4) == ".csv") {
    std::ifstream f(spec);
    if (!f) throw std::runtime_error("cannot open torque file '" + spec + "'");
    std::string line;
    if (!std::getline(f, line)) throw std::runtime_error(spec + ": empty file");
    auto head = split(line, ',');
    if (head.empty() || head[0] != "t") throw std::runtime_error(spec + ":1: header must start with 't'");
    for (size_t i = 1; i < head.size(); ++i) {
      const int d = velocity_index(sys, head[i]);
      if (d < 0) throw std::runtime_error(spec + ":1: unknown joint '" + head[i] + "'");
      csv_dofs_.push_back(d);
    }
    int ln = 1;
    while (std::getline(f, line)) {
      ++ln;
      if (line.empty()) continue;
      auto cells = split(line, ',');
      if (cells.size() != head.size()) throw std::runtime_error(spec + ":" + std::to_string(ln) + ": wrong number of columns");
      const double t = to_num(cells[0], spec + ":" + std::to_string(ln));
      if (!csv_t_.empty() && t < csv_t_.back()) throw std::runtime_error(spec + ":" + std::to_string(ln) + ": time goes backwards");
      csv_t_.push_back(t);
      std::vector<double> row;
      for (size_t i = 1; i < cells.size(); ++i) row.push_back(to_num(cells[i], spec + ":" + std::to_string(ln)));
      csv_rows_.push_back(row);
    }
    return;
  }
  auto p = split(spec, ':');
  if (p.size() < 3) throw std::runtime_error("torque profile '" + spec + "': expected JOINT:KIND:VALUE[:T0[:T1]]");
  Term t{};
  t.dof = velocity_index(sys, p[0]);
  if (t.dof < 0) throw std::runtime_error("torque profile '" + spec + "': unknown joint '" + p[0] + "'");
  t.value = to_num(p[2], spec);
  if (p[1] == "constant" && p.size() == 3) t.kind = 0;
  else if (p[1] == "step" && p.size() == 4) {
    t.kind = 1;
    t.t0 = to_num(p[3], spec);
  } else if (p[1] == "pulse" && p.size() == 5) {
    t.kind = 2;
    t.t0 = to_num(p[3], spec);
    t.t1 = to_num(p[4], spec);
  } else if (p[1] == "ramp" && p.size() == 5) {
    t.kind = 3;
    t.t0 = to_num(p[3], spec);
    t.t1 = to_num(p[4], spec);
    if (!(t.t1 > t.t0)) throw std::runtime_error("profile '" + spec + "': a ramp needs T1 > T0");
  } else {
    throw std::runtime_error("profile '" + spec + "': kinds are constant:V, step:V:T0, pulse:V:T0:T1, ramp:V:T0:T1");
  }
  terms_.push_back(t);
}

void TorqueProfile::eval(double t, Eigen::VectorXd& tau) const {
  tau.setZero();
  for (const Term& x : terms_) {
    if (x.kind == 3) {
      tau[x.dof] += t >= x.t1 ? x.value : t > x.t0 ? x.value * (t - x.t0) / (x.t1 - x.t0) : 0.0;
      continue;
    }
    const bool on = x.kind == 0 || (x.kind == 1 && t >= x.t0) || (x.kind == 2 && t >= x.t0 && t < x.t1);
    if (on) tau[x.dof] += x.value;
  }
  if (!csv_t_.empty() && t >= csv_t_.front()) {
    size_t i = 0;
    while (i + 1 < csv_t_.size() && csv_t_[i + 1] <= t) ++i;
    for (size_t k = 0; k < csv_dofs_.size(); ++k) tau[csv_dofs_[k]] += csv_rows_[i][k];
  }
}

}  // namespace coopdyn::cli

namespace coopdyn::cli {
std::vector<int> TorqueProfile::dofs() const {
  std::vector<int> d;
  for (const Term& x : terms_) d.push_back(x.dof);
  for (int x : csv_dofs_) d.push_back(x);
  std::sort(d.begin(), d.end());
  d.erase(std::unique(d.begin(), d.end()), d.end());
  return d;
}

std::vector<double> TorqueProfile::breakpoints() const {
  std::vector<double> b{0.0};
  for (const Term& x : terms_) {
    if (x.kind >= 1) b.push_back(x.t0);
    if (x.kind >= 2) b.push_back(x.t1);
  }
  for (double t : csv_t_) b.push_back(t);
  return b;
}
}  // namespace coopdyn::cli
