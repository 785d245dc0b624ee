#include "clients/cli/profile.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace coopdyn::cli {

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
