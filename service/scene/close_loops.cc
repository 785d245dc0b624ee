// Loops that close themselves: the initial state moved onto the constraints.
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "service/algorithms/kinematics.h"
#include "service/scene/builder.h"

namespace coopdyn::scene_detail {

// The YAML entry of a constraint, by name (for errors); the scene's root if it has none of its own.
YAML::Node constraint_node(const YAML::Node& root, const std::string& name) {
  const YAML::Node cs = root["constraints"];
  if (cs && cs.IsSequence())
    for (const YAML::Node& n : cs)
      if (n.IsMap() && n["name"] && n["name"].IsScalar() && n["name"].Scalar() == name) return n;
  return root;
}

namespace {
// The holonomic rows' position error and its Jacobian over `cols` at q (e2 returned: its squared norm).
struct Closing {
  const System& sys;
  const std::vector<int>& cols;
  Data d;
  ConstraintData cd;
  std::vector<int> hol;
  Eigen::MatrixXd J;
  Eigen::VectorXd e;
  Closing(const System& s, const std::vector<int>& c) : sys(s), cols(c), d(s.model), cd(s.model, s.constraints) {
    const ConstraintSet& set = sys.constraints;
    for (size_t k = 0; k < set.specs.size(); ++k)
      for (int r = 0; r < set.row_count[k]; ++r)
        if (set.specs[k].kind != ConstraintKind::kRolling || set.row_axis[k][r] == 5) hol.push_back(set.row_offset[k] + r);
    J.resize(hol.size(), cols.size());
    e.resize(hol.size());
  }
  double error_at(const Eigen::VectorXd& q, bool fill) {
    const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(sys.model.nv());
    forward_kinematics(sys.model, d, q, v0);
    constraint_rows(sys.model, d, sys.constraints, q, v0, cd);
    double e2 = 0;
    for (size_t i = 0; i < hol.size(); ++i) {
      e2 += cd.err[hol[i]] * cd.err[hol[i]];
      if (!fill) continue;
      e[i] = cd.err[hol[i]];
      for (size_t j = 0; j < cols.size(); ++j) J(i, j) = cd.G(hol[i], cols[j]);
    }
    return e2;
  }
  // The least-squares step over the columns not at a bound they would pass (active set: a column at
  // its bound whose step points out of the box is held and the step solved again); dx per column.
  Eigen::VectorXd step(const Eigen::VectorXd& q, const std::vector<int>& qi, const std::vector<double>& lo,
                       const std::vector<double>& hi, std::vector<char>& held) {
    std::fill(held.begin(), held.end(), 0);
    Eigen::VectorXd dx = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(cols.size()));
    for (size_t pass = 0; pass <= cols.size(); ++pass) {
      std::vector<int> f;
      for (size_t j = 0; j < cols.size(); ++j)
        if (!held[j]) f.push_back(static_cast<int>(j));
      Eigen::MatrixXd Jf(J.rows(), static_cast<Eigen::Index>(f.size()));
      for (size_t k = 0; k < f.size(); ++k) Jf.col(static_cast<Eigen::Index>(k)) = J.col(f[k]);
      const Eigen::VectorXd x = f.empty() ? Eigen::VectorXd() : Eigen::VectorXd(Jf.completeOrthogonalDecomposition().solve(e));
      dx.setZero();
      for (size_t k = 0; k < f.size(); ++k) dx[f[k]] = -x[static_cast<Eigen::Index>(k)];
      bool changed = false;
      for (int j : f) {
        if (qi[j] < 0) continue;
        const double x_j = q[qi[j]];
        if ((x_j <= lo[j] + 1e-12 && dx[j] < 0) || (x_j >= hi[j] - 1e-12 && dx[j] > 0)) held[j] = changed = true;
      }
      if (!changed) break;
    }
    return dx;
  }
};

// Gauss-Newton on the holonomic rows' position error over the velocity coordinates `cols`
// (min-norm steps), within the joint limits when `bounded` (System::q_lower, q_upper; a coordinate
// given beyond a limit may stay there but not go further): the bounded least change, by projected
// steps over an active set. Returns the largest position error left; *binding (if given) gets the
// columns held at a bound at the last step (the limits that keep the constraints open).
double close_over(const System& sys, const std::vector<int>& cols, Eigen::VectorXd& q, bool bounded,
                  std::vector<int>* binding = nullptr) {
  const Model& m = sys.model;
  Closing c(sys, cols);
  const size_t n = cols.size();
  std::vector<int> qi(n, -1);
  std::vector<double> lo(n, -HUGE_VAL), hi(n, HUGE_VAL);
  std::vector<char> held(n, 0);
  const bool has_limits = bounded && sys.q_lower.size() == m.nv() && sys.q_upper.size() == m.nv();
  for (size_t j = 0; j < n && has_limits; ++j) {
    const Joint& jt = m.bodies[m.dof_body[cols[j]]].joint;
    if (jt.nq != 1 || jt.nv != 1) continue;
    qi[j] = jt.idx_q;
    lo[j] = std::min(sys.q_lower[cols[j]], q[qi[j]]);
    hi[j] = std::max(sys.q_upper[cols[j]], q[qi[j]]);
  }
  Eigen::VectorXd dv = Eigen::VectorXd::Zero(m.nv());
  double e2 = c.error_at(q, true);
  Eigen::VectorXd q_try = q;
  for (int it = 0; it < 200 && e2 > 1e-28 && n > 0; ++it) {
    const Eigen::VectorXd x = c.step(q, qi, lo, hi, held);
    if (x.cwiseAbs().maxCoeff() == 0) break;  // every column that would help is at its bound
    // Gauss-Newton step, halved until the squared error drops (at most 0.5 rad or m per step),
    // each coordinate then put back within its bounds
    double step = std::min(1.0, 0.5 / std::max(1e-300, x.cwiseAbs().maxCoeff()));
    bool improved = false;
    for (int h = 0; h < 30 && !improved; ++h, step *= 0.5) {
      dv.setZero();
      for (size_t j = 0; j < n; ++j) dv[cols[j]] = step * x[static_cast<Eigen::Index>(j)];
      integrate(m, q, dv, 1.0, q_try);
      for (size_t j = 0; j < n; ++j)
        if (qi[j] >= 0) q_try[qi[j]] = std::clamp(q_try[qi[j]], lo[j], hi[j]);
      normalize_configuration(m, q_try);
      const double e2_try = c.error_at(q_try, false);
      if (e2_try < e2) {
        q = q_try;
        e2 = c.error_at(q, true);
        improved = true;
      }
    }
    if (!improved) break;  // a least-squares minimum that does not close (or round-off)
  }
  c.error_at(q, true);
  if (binding) {
    binding->clear();
    c.step(q, qi, lo, hi, held);
    for (size_t j = 0; j < n; ++j)
      if (held[j]) binding->push_back(cols[j]);
  }
  return c.e.size() ? c.e.cwiseAbs().maxCoeff() : 0.0;
}
}  // namespace

bool close_initial_state(System& sys, const std::vector<unsigned char>& q_given, const std::vector<unsigned char>& keep,
                         std::vector<std::string>* warnings, const std::vector<int>& held, Eigen::VectorXd* q_closest,
                         std::vector<std::pair<int, double>>* beyond) {
  const Model& m = sys.model;
  const ConstraintSet& set = sys.constraints;
  if (set.rows == 0) return true;
  Data d(m);
  ConstraintData cd(m, set);
  forward_kinematics(m, d, sys.q0, sys.v0);
  constraint_rows(m, d, set, sys.q0, sys.v0, cd);
  const double e0 = cd.err.cwiseAbs().maxCoeff(), g0 = cd.Gv.cwiseAbs().maxCoeff();
  const Eigen::VectorXd q_scene = sys.q0;
  if (e0 > 1e-9) {
    // with a keep list: every joint but those; else first the coordinates the scene gave no value,
    // then all (least change); pseudo-joints and held bodies never (they stay where the scene puts them)
    std::vector<int> open, all;
    std::string held_names;
    for (int bi = 0; bi < m.nbodies(); ++bi) {
      const Joint& j = m.bodies[bi].joint;
      const bool is_held = std::find(held.begin(), held.end(), bi) != held.end();
      if (is_held && j.nv > 0) held_names += (held_names.empty() ? "" : ", ") + j.name;
      if (j.pseudo || is_held) continue;
      bool given = false;
      for (int k = 0; k < j.nq; ++k) given = given || q_given[j.idx_q + k];
      const bool kept = !keep.empty() && keep[bi];
      for (int k = 0; k < j.nv; ++k) {
        if (!kept) all.push_back(j.idx_v + k);
        if (!given && keep.empty()) open.push_back(j.idx_v + k);
      }
    }
    const std::string held_note = held_names.empty() ? "" : " (" + held_names + " held where the scene puts it)";
    Eigen::VectorXd q = sys.q0;
    double left = HUGE_VAL;
    std::string which = "every joint not in close_initial_state.keep" + held_note;
    if (keep.empty()) {
      left = close_over(sys, open, q, true);
      which = "the coordinates the scene gives no initial value";
    }
    std::vector<int> binding;
    if (left > 1e-10) {
      q = sys.q0;
      left = close_over(sys, all, q, true, &binding);
      if (keep.empty()) which = "every coordinate (least change)" + held_note;
    }
    if (left > 1e-6) {  // the caller reports the constraint that stays open
      if (q_closest) *q_closest = q;
      Eigen::VectorXd q_free = sys.q0;
      if (beyond && !binding.empty() && close_over(sys, all, q_free, false) <= 1e-6) {
        // the limits keep it open: without them it closes
        beyond->clear();
        for (int i : binding) beyond->emplace_back(i, q_free[m.bodies[m.dof_body[i]].joint.idx_q]);
      }
      return false;
    }
    sys.q0 = q;
    std::ostringstream os;
    os.precision(6);
    os << "initial state: the constraints were open by " << e0 << " (rad, m); closed to " << left << " by moving " << which << ":";
    for (int i = 0; i < m.nq(); ++i)
      if (std::abs(sys.q0[i] - q_scene[i]) > 1e-12) {
        // the closed value in 17 digits: pasted back into the scene, it closes to round-off
        os << " " << m.q_names[i] << " " << q_scene[i] << " -> " << std::setprecision(17) << sys.q0[i] << std::setprecision(6);
      }
    os << " (close_initial_state: false keeps the scene's values and makes this an error)";
    warnings->push_back(os.str());
    // the locks hold the pseudo-joints where they are; welds to the world keep their targets
  }
  forward_kinematics(m, d, sys.q0, sys.v0);
  constraint_rows(m, d, set, sys.q0, sys.v0, cd);
  const double g1 = cd.Gv.cwiseAbs().maxCoeff();
  if (g1 > 1e-9) {
    std::vector<int> cols;
    for (int i = 0; i < m.nv(); ++i)
      if (!m.bodies[m.dof_body[i]].joint.pseudo) cols.push_back(i);
    Eigen::MatrixXd G(set.rows, cols.size());
    for (size_t j = 0; j < cols.size(); ++j) G.col(j) = cd.G.col(cols[j]);
    const Eigen::VectorXd x = G.completeOrthogonalDecomposition().solve(cd.Gv);
    const Eigen::VectorXd v_scene = sys.v0;
    for (size_t j = 0; j < cols.size(); ++j) sys.v0[cols[j]] -= x[j];
    std::ostringstream os;
    os.precision(6);
    os << "initial velocity: projected onto the constraints (velocity error " << std::max(g0, g1) << " -> 0):";
    for (int i = 0; i < m.nv(); ++i)
      if (std::abs(sys.v0[i] - v_scene[i]) > 1e-12) os << " " << m.v_names[i] << " " << v_scene[i] << " -> " << sys.v0[i];
    warnings->push_back(os.str());
  }
  return true;
}

}  // namespace coopdyn::scene_detail

namespace coopdyn::scene_detail {
namespace {
// where a joint's initial value was given: an arm's `q` entry, a robot body's `q: {JOINT: ...}`
// entry (with its limits' source), else nothing
YAML::Node joint_q_node(const Builder& B, const YAML::Node& root, const std::string& joint, std::string* source) {
  for (const ArmSpec& a : B.arms) {
    if (joint.rfind(a.name + ".", 0) != 0 || !a.node["q"] || !a.node["q"].IsSequence()) continue;
    for (size_t i = 0, k = 0; i < a.robot->joints.size(); ++i) {
      const ChainJoint& cj = a.robot->joints[i];
      if (cj.fixed) continue;
      if (a.name + "." + cj.name == joint && k < a.node["q"].size()) {
        *source = cj.source;
        return a.node["q"][k];
      }
      ++k;
    }
  }
  const YAML::Node bodies = root["bodies"];
  if (bodies && bodies.IsSequence())
    for (const YAML::Node& b : bodies) {
      if (!b.IsMap() || !b["name"] || !b["name"].IsScalar() || joint.rfind(b["name"].Scalar() + ".", 0) != 0) continue;
      const YAML::Node q = b["q"];
      const std::string jn = joint.substr(b["name"].Scalar().size() + 1);
      if (q && q.IsMap() && q[jn]) return q[jn];
      return b;
    }
  return YAML::Node(YAML::NodeType::Undefined);
}
}  // namespace

void refuse_beyond_limits(const Builder& B, const YAML::Node& root, const Eigen::VectorXd& q_closest,
                          const std::vector<std::pair<int, double>>& beyond) {
  const System& sys = B.sys;
  const Model& m = sys.model;
  std::ostringstream os;
  os.precision(6);
  os << "initial state: the constraints cannot close within the joint limits:";
  YAML::Node at(YAML::NodeType::Undefined);
  for (size_t k = 0; k < beyond.size(); ++k) {
    const int i = beyond[k].first;
    const double qc = q_closest[m.bodies[m.dof_body[i]].joint.idx_q];
    const bool upper = std::abs(qc - sys.q_upper[i]) <= std::abs(qc - sys.q_lower[i]);
    std::string source;
    const YAML::Node n = joint_q_node(B, root, m.v_names[i], &source);
    if (!at.IsDefined() && n.IsDefined()) at = n;
    os << (k ? ";" : "") << " joint " << m.v_names[i] << " binds at its " << (upper ? "upper" : "lower") << " limit "
       << (upper ? sys.q_upper[i] : sys.q_lower[i]) << (source.empty() ? "" : " (" + source + ")")
       << " (closing without limits would move it to " << beyond[k].second << ")";
  }
  // the constraint the closest state within the limits leaves most open
  Data d(m);
  ConstraintData cd(m, sys.constraints);
  forward_kinematics(m, d, q_closest, Eigen::VectorXd::Zero(m.nv()));
  constraint_rows(m, d, sys.constraints, q_closest, Eigen::VectorXd::Zero(m.nv()), cd);
  size_t worst = 0;
  double worst_e = -1;
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
    const double e = cd.err.segment(sys.constraints.row_offset[s], sys.constraints.row_count[s]).cwiseAbs().maxCoeff();
    if (e > worst_e) worst = s, worst_e = e;
  }
  os << "; within them constraint '" << sys.constraints.specs[worst].name << "' stays open by " << worst_e
     << " (rad, m). Other initial values or grasps, or close_initial_state: {keep: [...]} with other joints, may close it";
  fail(B.c, at.IsDefined() ? at : constraint_node(root, sys.constraints.specs[worst].name), os.str());
}

}  // namespace coopdyn::scene_detail
