// Helpers shared by the tests: scene paths, random states, finite differences, a plain KKT solve.
#pragma once

#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"
#include "tests/support/files.h"

namespace coopdyn::testing {

// A scene's warnings (the name kept from when a URDF's <dynamics> was reported unmodelled).
inline std::vector<std::string> warnings_besides_dynamics(const System& sys) {
  std::vector<std::string> w;
  for (const std::string& x : sys.warnings)
    if (x.find("the <dynamics> of ") == std::string::npos) w.push_back(x);
  return w;
}

inline const std::vector<std::string>& all_scenes() {
  static const std::vector<std::string> s = {"two_puma_load", "two_5dof_arms_load", "planar_arms_load", "four_bar", "two_iiwa_load"};
  return s;
}

// Wheel scenes (explicit trees with rolling constraints; no classic/pseudo-joint form). Kept apart
// from all_scenes(): their nonholonomic rows have velocity errors without a position error, which
// the generic weld checks over all_scenes() do not expect; tests/dynamics/wheel_test.cc covers them.
inline const std::vector<std::string>& wheel_scenes() {
  static const std::vector<std::string> s = {"unicycle", "two_wheel_vehicle", "four_wheel_car", "trike"};
  return s;
}

inline System load(const std::string& name, std::optional<Formulation> f = std::nullopt) {
  SceneOverrides ov;
  ov.formulation = f;
  return load_scene(scene_path(name), ov);
}

// A random configuration near q0 (joint angles perturbed, platform pose perturbed) and random v.
inline void random_state(const System& sys, std::mt19937& rng, double spread, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const Model& m = sys.model;
  Eigen::VectorXd dv(m.nv());
  for (int i = 0; i < m.nv(); ++i) dv[i] = spread * U(rng);
  q.resize(m.nq());
  integrate(m, sys.q0, dv, 1.0, q);
  v.resize(m.nv());
  for (int i = 0; i < m.nv(); ++i) v[i] = U(rng);
}

// Projects v onto the null space of G (so the constraints hold at velocity level).
inline Eigen::VectorXd project_velocity(const Eigen::MatrixXd& G, const Eigen::VectorXd& v) {
  if (G.rows() == 0) return v;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(G);
  return v - cod.solve(G * v);
}

// Plain KKT solve [M G^T; G 0][vdot; -lambda] = [tau - h; gamma], least squares / minimum norm.
inline void kkt_solve(const Eigen::MatrixXd& M, const Eigen::MatrixXd& G, const Eigen::VectorXd& tau_c,
                      const Eigen::VectorXd& gamma, Eigen::VectorXd& vdot, Eigen::VectorXd& lambda) {
  const int n = static_cast<int>(M.rows()), m = static_cast<int>(G.rows());
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n + m, n + m);
  K.topLeftCorner(n, n) = M;
  K.topRightCorner(n, m) = -G.transpose();
  K.bottomLeftCorner(m, n) = G;
  Eigen::VectorXd r(n + m);
  r << tau_c, gamma;
  Eigen::VectorXd x = K.completeOrthogonalDecomposition().solve(r);
  vdot = x.head(n);
  lambda = x.tail(m);
}

// Potential energy of gravity, -sum m_i g . c_i (J).
inline double potential_energy(const Model& m, const Eigen::VectorXd& q) {
  Data d(m);
  forward_kinematics(m, d, q, Eigen::VectorXd::Zero(m.nv()));
  double V = 0;
  for (int i = 0; i < m.nbodies(); ++i) {
    const Inertia& I = m.bodies[i].inertia;
    V -= I.m * m.gravity_W.dot(d.X_WB[i].R * I.c + d.X_WB[i].p);
  }
  return V;
}

// Kinetic (armatures included) plus potential energy (J).
inline double energy(const System& sys, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const Model& m = sys.model;
  Data d(m);
  forward_kinematics(m, d, q, v);
  crba(m, d);
  return 0.5 * v.dot(d.M * v) + potential_energy(m, q);
}

// Total spatial momentum of the bodies about the world origin, in world coordinates.
inline Vec6 total_momentum(const Model& m, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  Data d(m);
  forward_kinematics(m, d, q, v);
  Vec6 h = Vec6::Zero();
  // body velocity in B from V_W (taken at d.p_ref), momentum in B, then about the world origin
  for (int i = 0; i < m.nbodies(); ++i)
    h += d.X_WB[i].act_force(m.bodies[i].inertia * to_ref(d, d.X_WB[i]).inv_act(d.V_W[i]));
  return h;
}

// The text of a shipped scene, and a copy of a text with one occurrence replaced (the test fails
// if `from` is absent), for variants of the shipped scenes.
inline std::string scene_text(const std::string& name) { return slurp(scene_path(name)); }
inline std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  const auto p = text.find(from);
  EXPECT_NE(p, std::string::npos) << "not in the scene: " << from;
  if (p != std::string::npos) text.replace(p, from.size(), to);
  return text;
}

// A scene text without its `reactions:` line (the shipped scenes may ask for joint reactions).
inline std::string without_reactions(std::string text) {
  const auto p = text.find("\nreactions:");
  if (p != std::string::npos) text.erase(p, text.find('\n', p + 1) - p);
  return text;
}
// A shipped scene with every joint reaction asked for (`reactions: all`).
inline System load_with_reactions(const std::string& name, std::optional<Formulation> f = std::nullopt) {
  SceneOverrides ov;
  ov.formulation = f;
  return load_scene_string(without_reactions(scene_text(name)) + "\nreactions: all\n", scene_path(name), ov);
}

// The SceneError message of a scene text loaded as "car.yaml", or "(loaded)" when it loads.
inline std::string scene_error(const std::string& text) {
  try {
    load_scene_string(text, "car.yaml");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "(loaded)";
}

// The four-wheel car (text: config/scenes/four_wheel_car.yaml or an edit of it) with its steer
// joints' scene angles set (left, right; rad).
inline System car_with_steer(double dl, double dr, const std::string& text = scene_text("four_wheel_car")) {
  char a[96], b[96];
  std::snprintf(a, sizeof a, "name: fl_steer, pseudo: true, q: %.17g,", dl);
  std::snprintf(b, sizeof b, "name: fr_steer, pseudo: true, q: %.17g,", dr);
  std::string t = replace_once(text, "name: fl_steer, pseudo: true, q: 0,", a);
  t = replace_once(t, "name: fr_steer, pseudo: true, q: 0,", b);
  return load_scene_string(t, scene_path("four_wheel_car"));
}

// A rigid car: four wheels (r = 0.3 m) at the corners of a 2.6 m x 1.5 m, 1200 kg chassis, resting
// on the ground (tests/dynamics/state_fit_test.cc, tests/dynamics/free_directions_test.cc).
inline std::string rigid_car_scene() {
  return R"(
name: car
gravity: [0, 0, -9.81]
bodies:
  - {name: chassis, parent: world, joint: {type: floating, name: chassis, q: {xyz: [0, 0, 0.3]}},
     mass: 1200, inertia: [400, 1800, 2000, 0, 0, 0]}
  - {name: fl, parent: chassis, placement: {xyz: [1.3, 0.75, 0]},
     joint: {type: revolute, axis: [0, 1, 0], name: fl_spin}, mass: 15, inertia: [0.4, 0.7, 0.4, 0, 0, 0]}
  - {name: fr, parent: chassis, placement: {xyz: [1.3, -0.75, 0]},
     joint: {type: revolute, axis: [0, 1, 0], name: fr_spin}, mass: 15, inertia: [0.4, 0.7, 0.4, 0, 0, 0]}
  - {name: rl, parent: chassis, placement: {xyz: [-1.3, 0.75, 0]},
     joint: {type: revolute, axis: [0, 1, 0], name: rl_spin}, mass: 15, inertia: [0.4, 0.7, 0.4, 0, 0, 0]}
  - {name: rr, parent: chassis, placement: {xyz: [-1.3, -0.75, 0]},
     joint: {type: revolute, axis: [0, 1, 0], name: rr_spin}, mass: 15, inertia: [0.4, 0.7, 0.4, 0, 0, 0]}
constraints:
  - {name: fl, type: rolling, body: fl, axle: [0, 1, 0], radius: 0.3}
  - {name: fr, type: rolling, body: fr, axle: [0, 1, 0], radius: 0.3}
  - {name: rl, type: rolling, body: rl, axle: [0, 1, 0], radius: 0.3}
  - {name: rr, type: rolling, body: rr, axle: [0, 1, 0], radius: 0.3}
)";
}

// The vertical (world z) force the world exerts on all arm bases together, at the evaluation in ws.
inline double base_vertical_force(const System& sys, const Workspace& ws) {
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  double fz = 0;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].kind == WrenchKind::kBase)
      fz += wrench_frame_pose(sys, ws.data, static_cast<int>(k)).R.row(2).dot(wd.W[k].tail<3>());
  return fz;
}

// Velocity index of a coordinate name (-1 if absent).
inline int velocity_index_of(const System& sys, const std::string& name) {
  for (int i = 0; i < sys.model.nv(); ++i)
    if (sys.model.v_names[i] == name) return i;
  return -1;
}

// Index of a name in a list (-1 if absent).
inline int index_of(const std::vector<std::string>& v, const std::string& s) {
  for (size_t i = 0; i < v.size(); ++i)
    if (v[i] == s) return static_cast<int>(i);
  return -1;
}

}  // namespace coopdyn::testing
