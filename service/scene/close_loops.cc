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
// Gauss-Newton on the holonomic rows' position error over the velocity coordinates `cols`
// (min-norm steps), then v projected onto G v = 0 over all non-pseudo coordinates. Returns the
// largest position error left.
double close_over(const System& sys, const std::vector<int>& cols, Eigen::VectorXd& q) {
  const Model& m = sys.model;
  const ConstraintSet& set = sys.constraints;
  Data d(m);
  ConstraintData cd(m, set);
  std::vector<int> hol;
  for (size_t s = 0; s < set.specs.size(); ++s)
    for (int k = 0; k < set.row_count[s]; ++k)
      if (set.specs[s].kind != ConstraintKind::kRolling || set.row_axis[s][k] == 5) hol.push_back(set.row_offset[s] + k);
  Eigen::MatrixXd J(hol.size(), cols.size());
  Eigen::VectorXd e(hol.size()), dv = Eigen::VectorXd::Zero(m.nv());
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(m.nv());
  auto error_at = [&](const Eigen::VectorXd& qq, bool fill) {
    forward_kinematics(m, d, qq, v0);
    constraint_rows(m, d, set, qq, v0, cd);
    double e2 = 0;
    for (size_t i = 0; i < hol.size(); ++i) {
      e2 += cd.err[hol[i]] * cd.err[hol[i]];
      if (!fill) continue;
      e[i] = cd.err[hol[i]];
      for (size_t j = 0; j < cols.size(); ++j) J(i, j) = cd.G(hol[i], cols[j]);
    }
    return e2;
  };
  double e2 = error_at(q, true);
  Eigen::VectorXd q_try = q;
  for (int it = 0; it < 200 && e2 > 1e-28 && !cols.empty(); ++it) {
    const Eigen::VectorXd x = J.completeOrthogonalDecomposition().solve(e);
    // Gauss-Newton step, halved until the squared error drops (at most 0.5 rad or m per step)
    double step = std::min(1.0, 0.5 / std::max(1e-300, x.cwiseAbs().maxCoeff()));
    bool improved = false;
    for (int h = 0; h < 30 && !improved; ++h, step *= 0.5) {
      dv.setZero();
      for (size_t j = 0; j < cols.size(); ++j) dv[cols[j]] = -step * x[j];
      integrate(m, q, dv, 1.0, q_try);
      normalize_configuration(m, q_try);
      const double e2_try = error_at(q_try, false);
      if (e2_try < e2) {
        q = q_try;
        e2 = error_at(q, true);
        improved = true;
      }
    }
    if (!improved) break;  // a least-squares minimum that does not close (or round-off)
  }
  error_at(q, true);
  return e.size() ? e.cwiseAbs().maxCoeff() : 0.0;
}
}  // namespace

bool close_initial_state(System& sys, const std::vector<unsigned char>& q_given, const std::vector<unsigned char>& keep,
                         std::vector<std::string>* warnings, const std::vector<int>& held, Eigen::VectorXd* q_closest) {
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
      left = close_over(sys, open, q);
      which = "the coordinates the scene gives no initial value";
    }
    if (left > 1e-10) {
      q = sys.q0;
      left = close_over(sys, all, q);
      if (keep.empty()) which = "every coordinate (least change)" + held_note;
    }
    if (left > 1e-6) {  // the caller reports the constraint that stays open
      if (q_closest) *q_closest = q;
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
